//! `tessera info REPO [--json]`

use std::path::PathBuf;

use clap::Args;
use serde_json::json;
use tessera_core::repository::format::{section_name, AttributeErrorRecord};
use tessera_core::repository::patch::drawn_patch_bytes;

use crate::Outcome;

#[derive(Args)]
pub struct InfoArgs {
    /// Repository file.
    pub repository: PathBuf,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: InfoArgs) -> anyhow::Result<Outcome> {
    let repo = crate::repository_arg::open(&args.repository, "info")?;
    let h = repo.header();
    // One pass over the tet table, its pages dropped behind it (`scan_tets`): the peak
    // memory does not grow with the directory.
    let (mut leaves, mut patch_triangles, mut strip_indices, mut depth) = (0usize, 0u64, 0u64, 0);
    // Per level: simplices, stored (packed or raw) and drawn (decoded) patch bytes.
    let mut levels: Vec<(u64, u64, u64)> = Vec::new();
    let attributes = h.attributes;
    repo.scan_tets(|_, t| {
        let level = t.level as usize;
        if levels.len() <= level {
            levels.resize(level + 1, (0, 0, 0));
        }
        levels[level].0 += 1;
        levels[level].1 += t.patch_bytes as u64;
        levels[level].2 += drawn_patch_bytes(t, attributes);
        leaves += (t.first_child == u32::MAX) as usize;
        patch_triangles += t.triangle_count as u64;
        // Restart markers included: what the renderer's strip slots are made of.
        strip_indices += t.strip_index_count as u64;
        depth = depth.max(t.level);
    });
    let root_error = repo.diamonds().first().map_or(0.0, |d| d.error);
    // The attribute error table's largest errors, over the repository and per diamond level
    // (a diamond's level is that of the simplices it splits).
    let attribute_errors = repo.attribute_errors().map(|table| {
        let mut per_level: Vec<Option<AttributeErrorRecord>> = vec![None; levels.len()];
        for (d, r) in repo.diamonds().iter().zip(table) {
            if let Some(slot) = per_level.get_mut(d.level as usize) {
                *slot = Some(AttributeErrorRecord::max_of([&slot.unwrap_or_default(), r]));
            }
        }
        (AttributeErrorRecord::max_of(table), per_level)
    });
    // The UV error in texels: times the largest texture side, a bound for every texture (a
    // wedge's texture is not in the table). `None` without textures.
    let largest_side = crate::attribute_cut::largest_texture_side(&repo);
    let uv_texels = |uv: f32| largest_side.map(|side| uv * side as f32);
    let errors_json = |r: &AttributeErrorRecord| crate::attribute_cut::record_json(r, largest_side);
    let level_errors = |level: usize| {
        attribute_errors
            .as_ref()
            .and_then(|(_, per_level)| per_level[level].as_ref())
    };
    let (patch_blob_bytes, id_blob_bytes) = (repo.patch_blob().len(), repo.id_blob().len());
    let sections: Vec<_> = repo
        .sections()
        .iter()
        .map(|s| json!({"kind": section_name(s.kind), "offset": s.offset, "bytes": s.bytes}))
        .collect();
    let (stored, drawn) = levels
        .iter()
        .fold((0u64, 0u64), |(s, d), l| (s + l.1, d + l.2));
    let per_level: Vec<_> = levels
        .iter()
        .enumerate()
        .map(|(level, &(simplices, stored, drawn))| {
            json!({"level": level, "simplices": simplices, "stored_bytes": stored,
                   "decoded_bytes": drawn,
                   "attribute_errors": level_errors(level).map(errors_json)})
        })
        .collect();
    // Each texture: size, levels, pages and stored bytes (pages × the encoding's page bytes).
    let textures = repo.textures().map(|table| {
        let page_bytes = table.encoding().page_bytes() as u64;
        let list: Vec<_> = table
            .shapes()
            .iter()
            .map(|s| {
                let pages = s.page_count();
                json!({"width": s.width, "height": s.height, "levels": s.levels(),
                       "pages": pages, "bytes": pages as u64 * page_bytes})
            })
            .collect();
        json!({"count": list.len(), "bands": table.bands().len(), "pages": table.page_count(),
               "encoding": table.encoding().name(), "page_bytes": page_bytes,
               "textures": list})
    });
    let codec = repo.codec().name();
    let bits = position_bits(h);
    let value = json!({
        "format_version": h.version,
        "dimension": h.dimension,
        "attributes": {
            "normals": h.attributes & 1 != 0,
            "colors": h.attributes & 2 != 0,
            "uvs": h.attributes & 4 != 0,
        },
        "input_vertices": h.input_vertex_count,
        "input_triangles": h.input_triangle_count,
        "tetrahedra": h.tet_count,
        "leaves": leaves,
        "diamonds": h.diamond_count,
        "depth": depth,
        "patch_triangles": patch_triangles,
        "strip_indices": strip_indices,
        "root_error": root_error,
        "bbox_min": h.bbox_min,
        "bbox_max": h.bbox_max,
        "position_step": h.position_step,
        "position_bits": bits,
        "repository_bytes": repo.file_bytes(),
        "patch_blob_bytes": patch_blob_bytes,
        "id_blob_bytes": id_blob_bytes,
        "patch_codec": codec,
        "patch_stored_bytes": stored,
        "patch_decoded_bytes": drawn,
        "attribute_errors": attribute_errors.as_ref().map(|(all, _)| errors_json(all)),
        "textures": textures,
        "levels": per_level,
        "sections": sections,
    });
    if args.json {
        println!("{value}");
    } else {
        println!("{}", args.repository.display());
        println!("  format version {}, {}D", h.version, h.dimension);
        println!(
            "  input: {} triangles, {} vertices",
            h.input_triangle_count, h.input_vertex_count
        );
        println!(
            "  hierarchy: {} simplices ({} leaves), {} diamonds, depth {}",
            h.tet_count, leaves, h.diamond_count, depth
        );
        println!(
            "  patches: {patch_triangles} triangles over all levels in {strip_indices} strip \
             indices; root error {root_error:.3e}"
        );
        println!("  bbox: {:?} .. {:?}", h.bbox_min, h.bbox_max);
        let step = h.position_step;
        match bits {
            Some(b) => println!(
                "  positions: {b} bits per axis, step {:.3e} × {:.3e} × {:.3e}",
                step[0], step[1], step[2]
            ),
            None => println!(
                "  positions: step {:.3e} × {:.3e} × {:.3e}",
                step[0], step[1], step[2]
            ),
        }
        println!(
            "  {} bytes: patches {} ({codec}; {drawn} decoded, what the GPU holds), global ids \
             {} (CPU checks)",
            repo.file_bytes(),
            patch_blob_bytes,
            id_blob_bytes
        );
        if let Some((all, _)) = &attribute_errors {
            let texels = uv_texels(all.uv).map_or(String::new(), |t| format!(" ({t:.2} texels)"));
            println!(
                "  attribute errors (largest): colour {:.2} (8-bit RGB), normal {:.2} degrees, \
                 uv {:.3e}{texels}",
                all.colour, all.normal_degrees, all.uv
            );
        }
        if let Some(t) = &textures {
            println!(
                "  textures: {} ({} {} pages of {} bytes, {} bands)",
                t["count"],
                t["pages"],
                t["encoding"].as_str().unwrap_or_default(),
                t["page_bytes"],
                t["bands"]
            );
            for (i, s) in t["textures"].as_array().into_iter().flatten().enumerate() {
                println!(
                    "    {i}: {} × {}, {} levels, {} pages, {} bytes",
                    s["width"], s["height"], s["levels"], s["pages"], s["bytes"]
                );
            }
        }
        let header = match attribute_errors {
            Some(_) => "  colour  normal°        uv",
            None => "",
        };
        println!("  level  simplices      stored     decoded  ratio{header}");
        for (level, &(simplices, stored, drawn)) in levels.iter().enumerate() {
            let ratio = if stored > 0 {
                format!("{:.2}", drawn as f64 / stored as f64)
            } else {
                "-".into()
            };
            let errors = match (&attribute_errors, level_errors(level)) {
                (None, _) => String::new(),
                (Some(_), None) => format!("  {:>6} {:>8} {:>9}", "-", "-", "-"),
                (Some(_), Some(r)) => format!(
                    "  {:>6.2} {:>8.2} {:>9.2e}",
                    r.colour, r.normal_degrees, r.uv
                ),
            };
            println!("  {level:>5} {simplices:>10} {stored:>11} {drawn:>11}  {ratio:>5}{errors}");
        }
    }
    Ok(Outcome::Ok)
}

/// The bits per axis of the position grid (`build --position-bits`): the one B with
/// step = extent / (2^B − 1) on the widest axis; `None` for a flat box or a step no B gives
/// (a repository written by other means).
fn position_bits(h: &tessera_core::repository::Header) -> Option<u32> {
    let (extent, step) = (0..3)
        .map(|i| (h.bbox_max[i] - h.bbox_min[i], h.position_step[i]))
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    if !(extent > 0.0 && step > 0.0) {
        return None;
    }
    let levels = (extent / step).round();
    let bits = (levels + 1.0).log2().round();
    let exact =
        (1..=32).contains(&(bits as u32)) && ((2f64.powi(bits as i32) - 1.0) - levels).abs() < 0.5;
    exact.then_some(bits as u32)
}
