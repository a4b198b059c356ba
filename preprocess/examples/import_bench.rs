use std::time::Instant;
fn main() {
    for arg in std::env::args().skip(1) {
        let t = Instant::now();
        let raw = match tessera_preprocess::import::load_raw(arg.as_ref()) {
            Ok(r) => r,
            Err(e) => {
                println!("{arg}: ERROR {e}");
                continue;
            }
        };
        let t_read = t.elapsed().as_secs_f64();
        let r = tessera_preprocess::import::weld(raw);
        let total = t.elapsed().as_secs_f64();
        println!(
            "{arg}: {total:.3} s (read {t_read:.3} s, weld {:.3} s)  raw {} v / {} t  welded {} degenerate {} duplicate {} unreferenced {}  -> {} v / {} t  normals {} colors {} uvs {}",
            total - t_read, r.raw_vertices, r.raw_triangles, r.welded_vertices,
            r.degenerate_triangles, r.duplicate_triangles, r.unreferenced_vertices,
            r.mesh.positions.len(), r.mesh.triangles.len(),
            r.mesh.normals.is_some(), r.mesh.colors.is_some(), r.mesh.uvs.is_some()
        );
    }
}
