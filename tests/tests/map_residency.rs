//! The map's share of the process's resident set does not grow with the model (issue 11,
//! "nothing in the process grows with the model's size but the roots"): opening validates the
//! whole directory through the map and drops those pages from the resident set as it goes
//! (`Repository::release_pages`, `Repository::scan_tets`), and so does the streaming renderer
//! after each of its passes over the directory. Measured per mapping from /proc/self/smaps (Linux): the `Rss:` of the
//! mapping that holds the repository.

use tessera_core::repository::patch::drawn_patch_bytes;
use tessera_core::repository::Repository;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{BuildConfig, Construction};
use tessera_runtime::gpu::{GpuStreamer, RendererOptions};
use tessera_runtime::stream::UnitTable;
use tessera_tests::{build, gpu, testdata};

/// Resident bytes of the mapping that contains `address` (its `Rss:` in /proc/self/smaps).
fn mapping_rss(address: usize) -> u64 {
    let smaps = std::fs::read_to_string("/proc/self/smaps").expect("/proc/self/smaps");
    let mut inside = false;
    for line in smaps.lines() {
        let first = line.split_whitespace().next().unwrap_or("");
        if let Some((lo, hi)) = first.split_once('-') {
            if let (Ok(lo), Ok(hi)) = (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
            {
                inside = (lo..hi).contains(&address);
                continue;
            }
        }
        if inside {
            if let Some(kb) = line.strip_prefix("Rss:") {
                let kb = kb.trim().trim_end_matches("kB").trim();
                return kb.parse::<u64>().expect("an Rss line") * 1024;
            }
        }
    }
    panic!("no mapping holds {address:#x}");
}

fn directory_bytes(repo: &Repository) -> u64 {
    std::mem::size_of_val(repo.tets()) as u64 + std::mem::size_of_val(repo.diamonds()) as u64
}

#[cfg(target_os = "linux")]
#[test]
fn opening_and_streaming_leave_no_directory_pages_resident() {
    // Small leaves: a directory of a few hundred kilobytes from the bunny.
    let mesh = load_mesh(&testdata("mesh/bunny00.off"))
        .expect("import")
        .mesh;
    let config = BuildConfig {
        construction: Construction::LeafTriangles(64),
        ..BuildConfig::default()
    };
    let built = build(&mesh, &config);
    let path = built.dir.path().join("model.tsr");
    let page = 4096;

    let repo = std::sync::Arc::new(Repository::open(&path).expect("open"));
    let directory = directory_bytes(&repo);
    assert!(directory >= 64 * page, "a directory of {directory} bytes");
    let address = repo.tets().as_ptr() as usize;
    // Opening read the header, the section table and the whole directory; none of it stays
    // mapped in.
    let after_open = mapping_rss(address);
    assert!(
        after_open <= 2 * page,
        "{after_open} bytes resident after open"
    );

    // The measurement sees touched pages (so the assertions above can fail): a scan of the
    // directory maps it in, `release_pages` drops it again.
    let levels: u64 = repo.tets().iter().map(|t| t.level as u64).sum();
    assert!(levels > 0);
    let scanned = mapping_rss(address);
    assert!(
        scanned * 10 >= std::mem::size_of_val(repo.tets()) as u64 * 9,
        "{scanned} bytes resident after a scan of {directory}"
    );
    repo.release_pages();
    assert!(mapping_rss(address) <= 2 * page);

    // A pass with `scan_tets` drops the pages behind it, a mebibyte at a time: at its last
    // record it holds at most the last chunk, not the whole table.
    let tet_table = std::mem::size_of_val(repo.tets()) as u64;
    assert!(tet_table > (1 << 20) + 64 * page, "{tet_table}");
    let last = repo.tets().len() - 1;
    let mut at_last = 0;
    repo.scan_tets(|i, _| {
        if i == last {
            at_last = mapping_rss(address);
        }
    });
    assert!(
        at_last <= (1 << 20) + 2 * page,
        "{at_last} bytes resident at the last record of a {tet_table}-byte table"
    );
    assert!(mapping_rss(address) <= 2 * page);

    // The streaming renderer reads the whole directory to size its pools and unit table,
    // then keeps only what it reads as units land: here the roots.
    let ctx = gpu();
    let options = RendererOptions {
        width: 160,
        height: 90,
        budget_bytes: 4 << 20,
        ..Default::default()
    };
    let (_renderer, _streamer) =
        GpuStreamer::new(&ctx, repo.clone(), options, 1 << 20).expect("streamer");
    let streaming = mapping_rss(address);
    assert!(
        streaming <= 8 * page,
        "{streaming} bytes of the map resident after the streamer's setup (directory \
         {directory})"
    );
}

/// `UnitTable::from_repository` (two passes through the map, pages dropped behind them) builds
/// the table `UnitTable::new` builds from the whole slices.
#[test]
fn the_unit_table_read_through_the_map_is_the_one_from_the_slices() {
    let mesh = load_mesh(&testdata("mesh/bunny00.off"))
        .expect("import")
        .mesh;
    let config = BuildConfig {
        construction: Construction::LeafTriangles(64),
        ..BuildConfig::default()
    };
    let built = build(&mesh, &config);
    let repo = &built.repo;
    let a = UnitTable::new(
        repo.diamonds(),
        repo.tets(),
        repo.header().root_tet_count as usize,
        &|t| drawn_patch_bytes(t, repo.header().attributes),
    );
    let b = UnitTable::from_repository(repo);
    assert_eq!(a.len(), b.len());
    assert!(a.len() > 100, "{} units", a.len());
    assert_eq!((a.roots(), a.root_bytes()), (b.roots(), b.root_bytes()));
    for u in 0..a.len() as u32 {
        assert_eq!(a.simplices(u), b.simplices(u), "unit {u}");
        assert_eq!(a.bytes(u), b.bytes(u), "unit {u}");
        assert_eq!(a.children(u), b.children(u), "unit {u}");
        assert_eq!(a.parents(u), b.parents(u), "unit {u}");
        assert_eq!(a.level(u), b.level(u), "unit {u}");
    }
}
