//! The WGSL sources (one file per pass in `shaders/`, each prefixed by the shared records).

/// Records and uniforms shared by every pass.
const RECORDS: &str = include_str!("../../../shaders/records.wgsl");

/// Unpacking a stored position and placing it relative to the eye on the lattice, shared by the
/// draw pass and the position probe.
const POSITION: &str = include_str!("../../../shaders/position.wgsl");

/// The traversal compute pass (`traverse`).
pub fn traverse_source() -> String {
    format!(
        "{RECORDS}\n{}",
        include_str!("../../../shaders/traverse.wgsl")
    )
}

/// The compaction pass (`compact`): per page, prefix sums of the selected patches' strip slots
/// and the draw and expansion arguments.
pub fn compact_source() -> String {
    format!(
        "{RECORDS}\n{}",
        include_str!("../../../shaders/compact.wgsl")
    )
}

/// The expansion pass (`expand`): per page, 3 indices per selected strip slot.
pub fn expand_source() -> String {
    format!(
        "{RECORDS}\n{}",
        include_str!("../../../shaders/expand.wgsl")
    )
}

/// The draw pass (`vs_indexed`, `vs_main`; `fs_main`, the `fs_lit*` and `fs_check*` entries,
/// `fs_wire`).
pub fn draw_source() -> String {
    format!(
        "{RECORDS}\n{POSITION}\n{}",
        include_str!("../../../shaders/draw.wgsl")
    )
}

/// The draw pass with textures (`texture.wgsl` appended: the textured fill's `fs_lit*_textured`
/// and `fs_colour*_textured` entries, their bind group 2).
/// With `early_depth_test`, its fragment entries run after the depth test
/// (`@early_depth_test(force)`), so that hidden fragments request no page.
pub fn draw_textured_source(early_depth_test: bool) -> String {
    let textured = include_str!("../../../shaders/texture.wgsl");
    let textured = if early_depth_test {
        textured.replace("@fragment\n", "@fragment @early_depth_test(force)\n")
    } else {
        textured.to_string()
    };
    format!("{}\n{textured}", draw_source())
}

/// The position probe (`probe`): the draw pass's position functions over given positions
/// (`position_probe`).
pub fn position_probe_source() -> String {
    format!(
        "{RECORDS}\n{POSITION}\n{}",
        include_str!("../../../shaders/position_probe.wgsl")
    )
}

/// Threads per traversal workgroup: `@workgroup_size(64)` in traverse.wgsl.
pub const TRAVERSE_WORKGROUP: u32 = 64;
/// Threads per compaction workgroup: `@workgroup_size(256)` in compact.wgsl.
pub const COMPACT_WORKGROUP: u32 = 256;
/// The most workgroups a dispatch of ours asks for in one dimension: traverse.wgsl's
/// `MAX_WORKGROUPS` and the expansion's cap in compact.wgsl (threads stride over the rest).
/// An adapter below it is refused by name (`device.rs`).
pub const MAX_WORKGROUPS_PER_DIMENSION: u32 = 65_535;

#[cfg(test)]
mod tests {
    /// Both passes parse and validate with naga, the front end wgpu uses (no GPU needed).
    #[test]
    fn shaders_validate() {
        for (name, source) in [
            ("traverse", super::traverse_source()),
            ("compact", super::compact_source()),
            ("expand", super::expand_source()),
            ("draw", super::draw_source()),
            ("draw textured", super::draw_textured_source(false)),
            (
                "draw textured, early depth",
                super::draw_textured_source(true),
            ),
            ("position probe", super::position_probe_source()),
        ] {
            let module = naga::front::wgsl::parse_str(&source)
                .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&source)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        }
    }
}
