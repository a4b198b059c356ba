//! A repository given on the command line: every command that takes one opens it here, so a
//! mesh or a height field given by mistake is recognised (by its name or by its first bytes)
//! and answered with the `build` command that makes a repository of it (exit 2), not with a
//! complaint about the repository header.

use std::io::Read;
use std::path::Path;

use tessera_core::repository::Repository;

/// Opens the repository at `path` for `command` (e.g. `"render"`, `"bench stream"`), after
/// [`refuse_input_file`].
pub fn open(path: &Path, command: &str) -> anyhow::Result<Repository> {
    refuse_input_file(path, command)?;
    Ok(Repository::open(path)?)
}

/// Refuses a mesh or a DEM given where `command` expects a repository, saying which `build`
/// command makes one. A file named like an input but holding a repository passes; a file that
/// is neither is left to the repository reader's own message.
pub fn refuse_input_file(path: &Path, command: &str) -> anyhow::Result<()> {
    let mut head = Vec::with_capacity(HEAD_BYTES);
    let size = std::fs::metadata(path).map(|m| m.len()).ok();
    if let Ok(file) = std::fs::File::open(path) {
        let _ = file.take(HEAD_BYTES as u64).read_to_end(&mut head);
    }
    if head.starts_with(&tessera_core::repository::format::MAGIC) {
        return Ok(());
    }
    let Some(kind) = input_kind(path, &head, size) else {
        return Ok(());
    };
    let tsr = repository_name(path);
    anyhow::bail!(
        "{} is {kind}, not a tessera repository: build one first with `tessera build {} -o {}`, \
         then `tessera {command} {} …`",
        path.display(),
        path.display(),
        tsr.display(),
        tsr.display()
    );
}

/// How many leading bytes the content check reads.
const HEAD_BYTES: usize = 512;

/// `mesh.ply.gz` → `mesh.tsr`, `dem.npy` → `dem.tsr`.
fn repository_name(path: &Path) -> std::path::PathBuf {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let stem = Path::new(name).file_stem().unwrap_or_default();
    path.with_file_name(format!("{}.tsr", stem.to_string_lossy()))
}

/// What kind of input `path` holds, by its extension or else by its first bytes `head` (and
/// its `size`, for a binary STL's count); `None` when it looks like neither a mesh nor a DEM.
fn input_kind(path: &Path, head: &[u8], size: Option<u64>) -> Option<&'static str> {
    let name = path.to_string_lossy().to_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let has_extension = |list: &str| {
        list.split([',', ' '])
            .filter(|e| e.starts_with('.') && e.len() > 1)
            .any(|ext| name.ends_with(ext))
    };
    if has_extension(tessera_preprocess::import::SUPPORTED_EXTENSIONS) {
        return Some("an input mesh");
    }
    if has_extension(tessera_preprocess::dem::DEM_EXTENSIONS) {
        return Some("an input height field (DEM)");
    }
    content_kind(head, size)
}

/// The input kinds recognised by their first bytes, whatever the file is named.
fn content_kind(head: &[u8], size: Option<u64>) -> Option<&'static str> {
    const MESH: &str = "an input mesh";
    const DEM: &str = "an input height field (DEM)";
    let starts = |magic: &[u8]| head.starts_with(magic);
    if starts(b"\x1f\x8b") {
        return Some("a gzip-compressed file (an input mesh or DEM?)");
    }
    if starts(b"glTF") {
        return Some(MESH);
    }
    if starts(b"\x93NUMPY")
        || starts(b"PK\x03\x04")
        || starts(b"\x89PNG")
        || starts(b"II*\0")
        || starts(b"MM\0*")
        || starts(b"CDF\x01")
        || starts(b"CDF\x02")
    {
        return Some(DEM);
    }
    // Binary STL: an 80-byte header, a triangle count, 50 bytes a triangle.
    if let (Some(size), Some(count)) = (size, head.get(80..84)) {
        let count = u32::from_le_bytes(count.try_into().unwrap()) as u64;
        if size >= 84 && size == 84 + 50 * count {
            return Some(MESH);
        }
    }
    // The text formats, by their first meaningful line.
    let text = String::from_utf8_lossy(head);
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))?;
    let word = first.split_whitespace().next().unwrap_or("");
    match word {
        "ply" | "OFF" | "COFF" | "NOFF" | "CNOFF" | "STOFF" | "solid" => Some(MESH),
        "v" | "vn" | "vt" | "f" | "o" | "g" | "mtllib" | "usemtl" => Some(MESH),
        "P2" | "P5" => Some(DEM),
        _ if first.starts_with('{') => {
            if text.contains("\"asset\"") || text.contains("\"meshes\"") {
                Some(MESH)
            } else if text.contains("\"width\"") || text.contains("\"values\"") {
                Some(DEM)
            } else {
                None
            }
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_are_recognised_by_content_whatever_their_name() {
        let cases: &[(&[u8], Option<&str>)] = &[
            (b"ply\nformat ascii 1.0\n", Some("an input mesh")),
            (b"OFF\n3 1 0\n", Some("an input mesh")),
            (b"# made by hand\nv 0 0 0\nv 1 0 0\n", Some("an input mesh")),
            (b"solid cube\n facet normal", Some("an input mesh")),
            (b"glTF\x02\0\0\0", Some("an input mesh")),
            (
                b"{\"asset\": {\"version\": \"2.0\"}}",
                Some("an input mesh"),
            ),
            (
                b"{\"width\": 2, \"height\": 2, \"values\": [1,2,3,4]}",
                Some("an input height field (DEM)"),
            ),
            (b"\x93NUMPY\x01\x00", Some("an input height field (DEM)")),
            (b"CDF\x01\0\0\0\0", Some("an input height field (DEM)")),
            (b"P5\n2 2\n255\n", Some("an input height field (DEM)")),
            (b"hello, world\n", None),
            (b"", None),
        ];
        for (head, want) in cases {
            assert_eq!(
                content_kind(head, Some(head.len() as u64)),
                *want,
                "{:?}",
                String::from_utf8_lossy(head)
            );
        }
        let mut stl = [0u8; 84 + 50];
        stl[80] = 1;
        assert_eq!(content_kind(&stl[..84], Some(134)), Some("an input mesh"));
        assert_eq!(content_kind(&stl[..84], Some(135)), None);
    }

    #[test]
    fn the_suggested_repository_drops_the_compression_and_the_extension() {
        assert_eq!(
            repository_name(Path::new("a/b.ply.gz")),
            Path::new("a/b.tsr")
        );
        assert_eq!(repository_name(Path::new("dem.npy")), Path::new("dem.tsr"));
        assert_eq!(repository_name(Path::new("mesh")), Path::new("mesh.tsr"));
    }
}
