//! A repository's texture section (`tessera_core::repository::textures`) as the texture
//! cache's `PageSource`: pages borrowed from the memory map, each checked against its CRC on
//! first read by the reader.

use std::borrow::Cow;
use std::sync::Arc;

use tessera_core::repository::reader::Repository;
use tessera_core::texture::{Band, PageEncoding, TextureShape};

use super::texture_pages::PageSource;

/// The textures of one repository.
pub struct RepositoryPages {
    repo: Arc<Repository>,
    shapes: Vec<TextureShape>,
    bands: Vec<Band>,
    encoding: PageEncoding,
}

impl RepositoryPages {
    /// `None` where the repository has no texture section.
    pub fn new(repo: Arc<Repository>) -> Option<RepositoryPages> {
        let table = repo.textures()?;
        let (shapes, bands, encoding) = (table.shapes(), table.bands(), table.encoding());
        Some(RepositoryPages {
            repo,
            shapes,
            bands,
            encoding,
        })
    }

    /// `new` as the streamer takes it.
    pub fn source(repo: Arc<Repository>) -> Option<Arc<dyn PageSource>> {
        Self::new(repo).map(|p| Arc::new(p) as Arc<dyn PageSource>)
    }
}

impl PageSource for RepositoryPages {
    fn shapes(&self) -> &[TextureShape] {
        &self.shapes
    }

    fn bands(&self) -> &[Band] {
        &self.bands
    }

    fn encoding(&self) -> PageEncoding {
        self.encoding
    }

    fn page(&self, global: u32) -> Result<Cow<'_, [u8]>, String> {
        let table = (self.repo.textures()).ok_or("the repository has no texture section")?;
        table
            .page(global)
            .map(Cow::Borrowed)
            .map_err(|e| e.to_string())
    }
}
