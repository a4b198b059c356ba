//! Wavefront OBJ reader: `v` (with optional `r g b` vertex colours), `vt`, `vn` and `f`
//! (`v`, `v/vt`, `v//vn`, `v/vt/vn`, negative relative indices), all groups and objects merged
//! into one mesh; polygons fan-triangulated. `mtllib` and `usemtl`: a face takes the diffuse
//! colour (`Kd`) of its material as a face colour (its corners become wedges of that colour,
//! `sink::FaceColored`; refused when staged out of core), when the OBJ is read from a file
//! (the libraries are found beside it, `mtl.rs`) and its material has a `Kd`. Other statements
//! (`o`, `g`, `s`, `l`, `p`, ...) are ignored.
//!
//! Textures (`obj_textures.rs`): read into memory from a file, the faces of a material whose
//! `map_Kd` file exists are textured, each material's corners moved into a band of `v`; a
//! `map_Kd` file that does not exist is reported and its material drawn untextured. Staged
//! out of core, a face of a textured material is refused (one coordinate a vertex there).
//!
//! OBJ indexes texture coordinates and normals apart from positions. Read into memory, every
//! distinct `v/vt/vn` combination a face corner uses is a raw vertex of its own (the weld then
//! keeps those that differ in value as wedges of one vertex: texture seams and hard edges
//! survive); staged for the out-of-core build, a vertex takes those of the first face corner
//! that uses it. They are kept only if every face corner has them, colours only if every `v`
//! has them. One reader serves both imports: positions and colours go to a `MeshSink`,
//! texture coordinates, normals and corners to a [`CornerTracker`] (in memory, or staged on
//! disk and joined into vertex order at the end).

use std::path::Path;

use super::error::{show, ImportErrorKind as K, Location};
use super::input::{check_finite, fan, parse_float, parse_int, Input};
use super::mtl::{self, load_libraries, Material};
use super::obj_textures::place_obj_textures;
pub(crate) use super::obj_textures::{ObjTextures, NO_MATERIAL};
use super::sink::{at, FaceColored, MeshSink};
use super::textures::FoundTextures;
use super::RawMesh;
use crate::external::corner_attributes::{CornerStager, NONE};

enum Keyword {
    V,
    Vt,
    Vn,
    F,
    Mtllib,
    Usemtl,
    Other,
}

const UNSET: u32 = u32::MAX;

/// Resolves a 1-based (or negative, relative) OBJ index against `count` items.
fn resolve(raw: i64, count: usize, line: u64, what: &str) -> Result<u32, K> {
    let index = if raw > 0 { raw - 1 } else { count as i64 + raw };
    if raw == 0 {
        return Err(K::Syntax {
            at: Location::Line(line),
            msg: format!("{what} index 0 is invalid (OBJ indices start at 1)"),
        });
    }
    if index < 0 || index as usize >= count {
        if what == "vertex" {
            return Err(K::IndexOutOfRange {
                at: Location::Line(line),
                index: raw,
                count: count as u64,
            });
        }
        return Err(K::Syntax {
            at: Location::Line(line),
            msg: format!("{what} index {raw} out of range ({count} defined)"),
        });
    }
    Ok(index as u32)
}

/// Where an OBJ's `mtllib` libraries are read from.
#[derive(Clone, Copy)]
pub(crate) enum Libraries<'a> {
    /// Nowhere: bytes from no directory; materials colour nothing.
    None,
    /// Files named relative to this directory (the OBJ's).
    Dir(&'a Path),
    /// These bytes, whatever the name (the fuzz target's OBJ is its own library).
    Bytes(&'a [u8]),
}

/// Reads an OBJ file into memory, its material libraries from `libraries`. With `textures`
/// (and libraries read from a directory), the faces of materials whose `map_Kd` file exists
/// are textured: their corners' `v` moved into one band a material (`textures.rs`), the
/// corners of the other faces into a band without texture, and the textures returned; an
/// OBJ with no such face keeps its coordinates as read.
pub(crate) fn read(
    input: &mut Input,
    libraries: Libraries,
    textures: bool,
) -> Result<(RawMesh, FoundTextures), K> {
    let in_memory = |colors: bool| {
        Ok(FaceColored::new(RawMesh {
            colors: colors.then(Vec::new),
            ..Default::default()
        }))
    };
    let mut corners = CornerAttributes::default();
    let mut runs = Vec::new();
    let mode = if textures {
        ObjTextures::Track(&mut runs)
    } else {
        ObjTextures::Ignore
    };
    let (mut colored, facts) = read_into(input, libraries, in_memory, &mut corners, mode)?;
    let mesh = &mut colored.mesh;
    // A textured OBJ needs `vt` on the corners of its textured faces only: the others take a
    // coordinate of their band.
    let all_vt = facts.all_vt || facts.textured && facts.all_vt_textured;
    let keep = |all: bool, of: &[u32]| all && facts.triangles && of.iter().any(|&i| i != UNSET);
    let kept = [
        keep(all_vt, &corners.vt_of),
        keep(facts.all_vn, &corners.vn_of),
    ];
    corners.add_extra_vertices(mesh, facts.vertices, kept)?;
    mesh.uvs = keep(all_vt, &corners.vt_of).then(|| {
        (corners.vt_of.iter())
            .map(|&i| {
                corners
                    .texcoords
                    .get(i as usize)
                    .copied()
                    .unwrap_or_default()
            })
            .collect()
    });
    mesh.normals = keep(facts.all_vn, &corners.vn_of).then(|| {
        (corners.vn_of.iter())
            .map(|&i| corners.normals.get(i as usize).copied().unwrap_or_default())
            .collect()
    });
    // After the extra vertices and their attributes: each face colour's corner copies them.
    let mut mesh = colored.finish();
    let mut found = FoundTextures {
        textures: None,
        missing: facts.missing,
    };
    if facts.textured && mesh.uvs.is_some() {
        let material_of = expand_runs(&runs, mesh.triangles.len());
        let placed = place_obj_textures(&mut mesh, &facts.materials, &material_of)?;
        found.textures = Some(placed);
    }
    Ok((mesh, found))
}

/// Each of `triangles` triangles' material, from the runs of one material `ObjTextures::Track`
/// records (first triangle, material).
fn expand_runs(runs: &[(usize, u32)], triangles: usize) -> Vec<u32> {
    let mut out = Vec::with_capacity(triangles);
    for (k, &(first, material)) in runs.iter().enumerate() {
        let end = runs.get(k + 1).map_or(triangles, |&(next, _)| next);
        debug_assert_eq!(out.len(), first);
        out.extend(std::iter::repeat_n(material, end - first));
    }
    out
}

/// Where an OBJ reader puts its `vt` and `vn` values and its face corners' indices into them
/// (checked against the values read so far): in memory ([`CornerAttributes`]) or on disk
/// (`external::corner_attributes::CornerStager`, the out-of-core build's import).
pub(crate) trait CornerTracker {
    /// A `v` statement: the next vertex.
    fn vertex(&mut self);
    fn texcoord(&mut self, uv: [f32; 2]) -> Result<(), K>;
    fn normal(&mut self, n: [f32; 3]) -> Result<(), K>;
    /// A face corner; returns the raw vertex the face uses there.
    fn corner(&mut self, v: u32, vt: Option<u32>, vn: Option<u32>) -> Result<u32, K>;
}

/// The texture coordinates and normals an OBJ's face corners give its vertices, in memory:
/// the `vt` and `vn` values and, per vertex, the indices of its first corner's; the corners
/// with other indices get extra vertices (`add_extra_vertices`).
#[derive(Default)]
struct CornerAttributes {
    texcoords: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
    vt_of: Vec<u32>,
    vn_of: Vec<u32>,
    /// Whether a corner used the vertex yet.
    seen: Vec<bool>,
    /// (vertex, vt, vn) of each extra vertex, and its number by those.
    extra: Vec<[u32; 3]>,
    extra_of: rustc_hash::FxHashMap<[u32; 3], u32>,
}

/// Where a face names an extra vertex until the file's vertex count is known: `EXTRA | k`.
const EXTRA: u32 = 1 << 31;

impl CornerAttributes {
    /// Appends the extra vertices (a copy of their vertex's position and colour, their own
    /// `vt` and `vn`) after the file's `vertices`, and points the faces at them; an extra
    /// vertex that differs from its vertex's first corner only in an attribute the mesh does
    /// not keep (`kept`: texture coordinates, normals) is that vertex.
    fn add_extra_vertices(
        &mut self,
        mesh: &mut RawMesh,
        vertices: u64,
        kept: [bool; 2],
    ) -> Result<(), K> {
        if self.extra.is_empty() {
            return Ok(());
        }
        let differs = |&[v, vt, vn]: &[u32; 3], this: &Self| {
            kept[0] && vt != this.vt_of[v as usize] || kept[1] && vn != this.vn_of[v as usize]
        };
        let real = self.extra.iter().filter(|e| differs(e, self)).count();
        if vertices + real as u64 > EXTRA as u64 {
            return Err(K::TooLarge {
                at: Location::None,
                msg: format!(
                    "{vertices} vertices and {} more for their texture coordinate and normal \
                     combinations: at most {EXTRA} in memory",
                    real
                ),
            });
        }
        let mut id_of = Vec::with_capacity(self.extra.len());
        for k in 0..self.extra.len() {
            let [v, vt, vn] = self.extra[k];
            if !differs(&self.extra[k], self) {
                id_of.push(v);
                continue;
            }
            id_of.push(mesh.positions.len() as u32);
            mesh.positions.push(mesh.positions[v as usize]);
            if let Some(c) = &mut mesh.colors {
                c.push(c[v as usize]);
            }
            self.vt_of.push(vt);
            self.vn_of.push(vn);
        }
        for t in &mut mesh.triangles {
            for v in t {
                if *v >= EXTRA {
                    *v = id_of[(*v - EXTRA) as usize];
                }
            }
        }
        Ok(())
    }
}

impl CornerTracker for CornerAttributes {
    fn vertex(&mut self) {
        self.vt_of.push(UNSET);
        self.vn_of.push(UNSET);
        self.seen.push(false);
    }
    fn texcoord(&mut self, uv: [f32; 2]) -> Result<(), K> {
        self.texcoords.push(uv);
        Ok(())
    }
    fn normal(&mut self, n: [f32; 3]) -> Result<(), K> {
        self.normals.push(n);
        Ok(())
    }
    fn corner(&mut self, v: u32, vt: Option<u32>, vn: Option<u32>) -> Result<u32, K> {
        let (vt, vn) = (vt.unwrap_or(UNSET), vn.unwrap_or(UNSET));
        let at = v as usize;
        if !self.seen[at] {
            self.seen[at] = true;
            (self.vt_of[at], self.vn_of[at]) = (vt, vn);
            return Ok(v);
        }
        if (self.vt_of[at], self.vn_of[at]) == (vt, vn) {
            return Ok(v);
        }
        if v >= EXTRA {
            return Err(K::TooLarge {
                at: Location::None,
                msg: format!("vertex {v} with several texture coordinates or normals: at most {EXTRA} vertices in memory"),
            });
        }
        let next = self.extra.len() as u32;
        let k = *self.extra_of.entry([v, vt, vn]).or_insert(next);
        if k == next {
            if next >= EXTRA {
                return Err(K::TooLarge {
                    at: Location::None,
                    msg: format!("more than {EXTRA} texture coordinate and normal combinations"),
                });
            }
            self.extra.push([v, vt, vn]);
        }
        Ok(EXTRA | k)
    }
}

/// Corners checked and forgotten (`import::find_textures` reads an OBJ for its materials).
pub(crate) struct NoCorners;

impl CornerTracker for NoCorners {
    fn vertex(&mut self) {}
    fn texcoord(&mut self, _: [f32; 2]) -> Result<(), K> {
        Ok(())
    }
    fn normal(&mut self, _: [f32; 3]) -> Result<(), K> {
        Ok(())
    }
    fn corner(&mut self, v: u32, _: Option<u32>, _: Option<u32>) -> Result<u32, K> {
        Ok(v)
    }
}

impl CornerTracker for CornerStager {
    fn vertex(&mut self) {}
    fn texcoord(&mut self, uv: [f32; 2]) -> Result<(), K> {
        CornerStager::texcoord(self, uv).map_err(K::Io)
    }
    fn normal(&mut self, n: [f32; 3]) -> Result<(), K> {
        CornerStager::normal(self, n).map_err(K::Io)
    }
    fn corner(&mut self, v: u32, vt: Option<u32>, vn: Option<u32>) -> Result<u32, K> {
        let (vt, vn) = (vt.unwrap_or(NONE), vn.unwrap_or(NONE));
        CornerStager::corner(self, v, vt, vn).map_err(K::Io)?;
        Ok(v)
    }
}

/// What decides an OBJ's attributes once it is read: a vertex keeps its first corner's
/// texture coordinate (normal) only if every face corner has one (`all_vt`, `all_vn`) and
/// the file has a triangle.
pub(crate) struct ObjFacts {
    pub all_vt: bool,
    pub all_vn: bool,
    pub triangles: bool,
    pub vertices: u64,
    /// The materials of the libraries read, each with whether its `map_Kd` file exists
    /// (only looked up with `ObjTextures::Track` or `Refuse` and libraries in a directory).
    pub materials: Vec<(Material, bool)>,
    /// Whether a face's material has an existing `map_Kd` (tracked or refused textures).
    pub textured: bool,
    /// Whether every corner of those faces has a `vt`.
    pub all_vt_textured: bool,
    /// `map_Kd` files a face's material names that do not exist, once each.
    pub missing: Vec<String>,
}

/// Reads an OBJ file into the sink `make_sink(colors)` makes at the first vertex (`colors`:
/// whether it has a colour; the sink is told to forget them if a later vertex has none), the
/// texture coordinates, normals and face corners into `corners`; the faces of a material with
/// a `Kd` (libraries read from `libraries`) are given its colour (`MeshSink::face_color`).
pub(crate) fn read_into<S: MeshSink>(
    input: &mut Input,
    libraries: Libraries,
    make_sink: impl FnOnce(bool) -> Result<S, K>,
    corners: &mut impl CornerTracker,
    mut textures: ObjTextures,
) -> Result<(S, ObjFacts), K> {
    let mut make_sink = Some(make_sink);
    let mut sink: Option<S> = None;
    let mut vertices: u64 = 0;
    let mut all_colored = true;
    let mut facts = ObjFacts {
        all_vt: true,
        all_vn: true,
        triangles: false,
        vertices: 0,
        materials: Vec::new(),
        textured: false,
        all_vt_textured: true,
        missing: Vec::new(),
    };
    let look_up_maps = !matches!(textures, ObjTextures::Ignore);
    // `vt` and `vn` statements read so far (the range their indices are checked against).
    let (mut texcoord_count, mut normal_count) = (0usize, 0usize);
    let mut fanned: Vec<[u32; 3]> = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    let mut vals = [0.0f64; 8];
    // The material in use (an index into `facts.materials`), its `Kd` and whether its
    // `map_Kd` file exists.
    let mut material = NO_MATERIAL;
    let mut face_color: Option<[u8; 4]> = None;
    let mut textured = false;
    let mut triangle_count = 0usize;

    while input.skip_blank(true)? {
        let line = input.line;
        let keyword = match input.token(true)? {
            Some(b"v") => Keyword::V,
            Some(b"vt") => Keyword::Vt,
            Some(b"vn") => Keyword::Vn,
            Some(b"f") => Keyword::F,
            Some(b"mtllib") => Keyword::Mtllib,
            Some(b"usemtl") => Keyword::Usemtl,
            _ => Keyword::Other,
        };
        if let Keyword::Other = keyword {
            input.skip_line()?;
            continue;
        }
        if let Keyword::Mtllib | Keyword::Usemtl = keyword {
            let mut words = Vec::new();
            while let Some(tok) = input.token(true)? {
                words.push(String::from_utf8_lossy(tok).into_owned());
            }
            input.end_line(true)?;
            match keyword {
                // Each word a library (names with spaces are not told apart from two names).
                Keyword::Mtllib => match libraries {
                    Libraries::Dir(base) => {
                        let found = load_libraries(base, &words)?.into_iter().map(|m| {
                            let exists =
                                look_up_maps && m.diffuse_map.as_ref().is_some_and(|p| p.is_file());
                            (m, exists)
                        });
                        facts.materials.extend(found);
                    }
                    Libraries::Bytes(bytes) => {
                        let found = mtl::parse(bytes)?.into_iter().map(|m| (m, false));
                        facts.materials.extend(found);
                    }
                    Libraries::None => {}
                },
                // A name with spaces, as `newmtl` keeps it; the last definition wins.
                _ => {
                    let name = words.join(" ");
                    let found = facts.materials.iter().rposition(|(m, _)| m.name == name);
                    material = found.map_or(NO_MATERIAL, |i| i as u32);
                    let (m, exists) = match found {
                        Some(i) => (Some(&facts.materials[i].0), facts.materials[i].1),
                        None => (None, false),
                    };
                    face_color = m.and_then(|m| m.diffuse);
                    textured = exists;
                    if let (Some(map), false, true) =
                        (m.and_then(|m| m.diffuse_map.as_ref()), exists, look_up_maps)
                    {
                        let map = map.display().to_string();
                        if matches!(libraries, Libraries::Dir(_)) && !facts.missing.contains(&map) {
                            facts.missing.push(map);
                        }
                    }
                }
            }
            continue;
        }
        if let Keyword::F = keyword {
            poly.clear();
            let mut face_all_vt = true;
            while let Some(tok) = input.token(true)? {
                let mut parts = tok.split(|&c| c == b'/');
                let index = |part: Option<&[u8]>| -> Result<Option<i64>, K> {
                    match part {
                        None | Some(b"") => Ok(None),
                        Some(p) => parse_int(p).map(Some).ok_or_else(|| K::Syntax {
                            at: Location::Line(line),
                            msg: format!("invalid face vertex '{}'", show(tok)),
                        }),
                    }
                };
                let v = index(parts.next())?;
                let vt = index(parts.next())?;
                let vn = index(parts.next())?;
                let Some(v) = v else {
                    return Err(K::Syntax {
                        at: Location::Line(line),
                        msg: format!("invalid face vertex '{}'", show(tok)),
                    });
                };
                let v = resolve(v, vertices as usize, line, "vertex")?;
                let vt = vt
                    .map(|vt| resolve(vt, texcoord_count, line, "texture coordinate"))
                    .transpose()?;
                let vn = vn
                    .map(|vn| resolve(vn, normal_count, line, "normal"))
                    .transpose()?;
                facts.all_vt &= vt.is_some();
                face_all_vt &= vt.is_some();
                facts.all_vn &= vn.is_some();
                poly.push(corners.corner(v, vt, vn)?);
            }
            input.end_line(true)?;
            fanned.clear();
            fan(&poly, &mut fanned);
            if !fanned.is_empty() {
                facts.triangles = true;
                if textured {
                    if let ObjTextures::Refuse = textures {
                        return Err(K::Unsupported {
                            at: Location::Line(line),
                            what: "a textured OBJ in the out-of-core build (--memory keeps one \
                                   texture coordinate a vertex; build without --memory, or \
                                   with --no-textures)"
                                .into(),
                        });
                    }
                    facts.textured = true;
                    facts.all_vt_textured &= face_all_vt;
                }
                if let ObjTextures::Track(runs) = &mut textures {
                    if runs.last().is_none_or(|&(_, m)| m != material) {
                        runs.push((triangle_count, material));
                    }
                }
                triangle_count += fanned.len();
                // A face comes after a vertex it uses, so the sink exists.
                let sink = sink.as_mut().expect("a face after its vertices");
                sink.triangles(&fanned)?;
                if let Some(color) = face_color {
                    sink.face_color(fanned.len(), color)?;
                }
            }
            continue;
        }

        let mut n = 0;
        while let Some(tok) = input.token(true)? {
            if n == vals.len() {
                return Err(K::Syntax {
                    at: Location::Line(line),
                    msg: "too many values".into(),
                });
            }
            vals[n] = parse_float(tok).ok_or_else(|| K::Syntax {
                at: Location::Line(line),
                msg: format!("invalid number '{}'", show(tok)),
            })?;
            n += 1;
        }
        input.end_line(true)?;
        let count_err = |what: &str, expected: &str| K::Syntax {
            at: Location::Line(line),
            msg: format!("{what} with {n} values, expected {expected}"),
        };
        match keyword {
            Keyword::V => {
                if !(3..=7).contains(&n) {
                    return Err(count_err(
                        "vertex",
                        "3, 4 (x y z w) or 6, 7 (x y z r g b [a])",
                    ));
                }
                let p = [vals[0], vals[1], vals[2]];
                check_finite(p, vertices, || Location::Line(line))?;
                if vertices > u32::MAX as u64 {
                    return Err(K::TooLarge {
                        at: Location::Line(line),
                        msg: format!("more than {} vertices", u32::MAX as u64 + 1),
                    });
                }
                let mut vertex = at(p);
                if n >= 6 {
                    let c = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
                    let a = if n == 7 { c(vals[6]) } else { 255 };
                    vertex.color = [c(vals[3]), c(vals[4]), c(vals[5]), a];
                } else if all_colored {
                    all_colored = false;
                    if let Some(sink) = sink.as_mut() {
                        sink.forget_colors();
                    }
                }
                if let Some(make) = make_sink.take() {
                    sink = Some(make(all_colored)?);
                }
                sink.as_mut().expect("made above").vertex(&vertex)?;
                vertices += 1;
                corners.vertex();
            }
            Keyword::Vt => {
                if !(1..=3).contains(&n) {
                    return Err(count_err("texture coordinate", "1 to 3"));
                }
                texcoord_count += 1;
                corners.texcoord([vals[0] as f32, if n > 1 { vals[1] as f32 } else { 0.0 }])?;
            }
            Keyword::Vn => {
                if n != 3 {
                    return Err(count_err("normal", "3"));
                }
                normal_count += 1;
                corners.normal([vals[0] as f32, vals[1] as f32, vals[2] as f32])?;
            }
            Keyword::F | Keyword::Mtllib | Keyword::Usemtl | Keyword::Other => unreachable!(),
        }
    }
    let sink = match (sink, make_sink) {
        (Some(sink), _) => sink,
        // No vertex at all: an empty mesh.
        (None, Some(make)) => make(false)?,
        (None, None) => unreachable!("the sink is made when taken"),
    };
    facts.vertices = vertices;
    Ok((sink, facts))
}
