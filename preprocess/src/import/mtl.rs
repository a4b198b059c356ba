//! Wavefront MTL material libraries, as far as appearance goes: each `newmtl`'s diffuse colour
//! (`Kd r g b`, 0..1, clamped; alpha from `d`, or `1 - Tr`) and diffuse texture (`map_Kd
//! [options] FILE`, the file name being the statement's last word; `\` read as `/`, so a
//! Windows-written `.\skin.jpg` resolves). Everything else is ignored. An OBJ's faces take the
//! colour of the material `usemtl` names (`obj.rs`); a material without `Kd` colours nothing.

use std::path::{Path, PathBuf};

use super::error::{show, ImportErrorKind as K, Location};
use super::input::parse_float;

/// One material of a library.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Material {
    pub name: String,
    /// `Kd` (and `d` / `Tr` as alpha), as 8-bit RGBA; none without `Kd`.
    pub diffuse: Option<[u8; 4]>,
    /// `map_Kd`'s file, relative to the library's directory as written (`\` as `/`).
    pub diffuse_map: Option<PathBuf>,
}

/// The materials of an MTL file's bytes, in order. Malformed numbers are errors (with their
/// line); unknown statements are skipped.
pub fn parse(bytes: &[u8]) -> Result<Vec<Material>, K> {
    let mut materials: Vec<Material> = Vec::new();
    let mut alpha: Vec<Option<f64>> = Vec::new();
    for (i, line) in bytes.split(|&c| c == b'\n').enumerate() {
        let line_no = i as u64 + 1;
        let line = line.split(|&c| c == b'#').next().unwrap_or_default();
        let mut words = line
            .split(|c| c.is_ascii_whitespace())
            .filter(|w| !w.is_empty());
        let Some(keyword) = words.next() else {
            continue;
        };
        let rest: Vec<&[u8]> = words.collect();
        let numbers = |n: usize| -> Result<Vec<f64>, K> {
            let bad = |w: &[u8]| K::Syntax {
                at: Location::Line(line_no),
                msg: format!("invalid number '{}' in '{}'", show(w), show(keyword)),
            };
            if rest.len() < n {
                return Err(K::Syntax {
                    at: Location::Line(line_no),
                    msg: format!("'{}' needs {n} values, has {}", show(keyword), rest.len()),
                });
            }
            rest[..n]
                .iter()
                .map(|w| {
                    parse_float(w)
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| bad(w))
                })
                .collect()
        };
        let current = materials.last_mut();
        match (keyword, current) {
            (b"newmtl", _) => {
                let name = rest.iter().map(|w| show(w)).collect::<Vec<_>>().join(" ");
                materials.push(Material {
                    name,
                    ..Default::default()
                });
                alpha.push(None);
            }
            // `Kd spectral FILE` and `Kd xyz X Y Z` are not RGB: skipped.
            (b"Kd", Some(m)) if !rest.is_empty() && parse_float(rest[0]).is_some() => {
                // `Kd r` alone means r = g = b.
                let v = numbers(1)?;
                let rgb = match rest.len() {
                    1 | 2 => [v[0]; 3],
                    _ => numbers(3)?.try_into().expect("three values"),
                };
                let c = rgb.map(unit_to_u8);
                m.diffuse = Some([c[0], c[1], c[2], 255]);
            }
            (b"d", Some(_)) if !rest.is_empty() && rest[0] != b"-halo" => {
                *alpha.last_mut().expect("one per material") = Some(numbers(1)?[0]);
            }
            (b"Tr", Some(_)) if !rest.is_empty() => {
                *alpha.last_mut().expect("one per material") = Some(1.0 - numbers(1)?[0]);
            }
            (b"map_Kd", Some(m)) => {
                if let Some(file) = rest.last() {
                    let name = String::from_utf8_lossy(file).replace('\\', "/");
                    m.diffuse_map = Some(PathBuf::from(name));
                }
            }
            _ => {}
        }
    }
    for (m, a) in materials.iter_mut().zip(alpha) {
        if let (Some(c), Some(a)) = (&mut m.diffuse, a) {
            c[3] = unit_to_u8(a);
        }
    }
    Ok(materials)
}

fn unit_to_u8(x: f64) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The materials of the libraries an OBJ names (`mtllib A.mtl B.mtl`, relative to `base`, the
/// OBJ's directory): a library that cannot be read is skipped (OBJ files often name one that
/// was not shipped with them), a malformed one is an error naming it. Texture files are
/// resolved against the library's directory.
pub fn load_libraries(base: &Path, names: &[String]) -> Result<Vec<Material>, K> {
    let mut all = Vec::new();
    for name in names {
        let path = base.join(name.replace('\\', "/"));
        let Ok(bytes) = std::fs::read(&path) else {
            continue;
        };
        let dir = path.parent().unwrap_or(base).to_path_buf();
        let materials = parse(&bytes).map_err(|e| K::Syntax {
            at: Location::Other(path.display().to_string()),
            msg: e.to_string(),
        })?;
        all.extend(materials.into_iter().map(|mut m| {
            m.diffuse_map = m.diffuse_map.map(|t| dir.join(t));
            m
        }));
    }
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_alpha_and_maps() {
        let mtl = b"# lib\nnewmtl red\nKd 1 0 0\nd 0.5\nnewmtl grey skin\nKd 0.8\n\
                    map_Kd -s 1 1 1 .\\tex\\skin.jpg\nnewmtl bare\nKs 1 1 1\n\
                    newmtl clear\nKd 0 0.5 1.5\nTr 0.25\nnewmtl spec\nKd spectral x.rfl\n";
        let m = parse(mtl).unwrap();
        assert_eq!(m.len(), 5);
        assert_eq!(m[0].name, "red");
        assert_eq!(m[0].diffuse, Some([255, 0, 0, 128]));
        assert_eq!(m[1].name, "grey skin");
        assert_eq!(m[1].diffuse, Some([204, 204, 204, 255]));
        assert_eq!(m[1].diffuse_map, Some(PathBuf::from("./tex/skin.jpg")));
        assert_eq!(m[2].diffuse, None);
        assert_eq!(m[3].diffuse, Some([0, 128, 255, 191]));
        assert_eq!(m[4].diffuse, None);
    }

    #[test]
    fn malformed_numbers_are_errors_with_their_line() {
        let e = parse(b"newmtl a\nKd 1 x 0\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("'x'"), "{e}");
        let e = parse(b"newmtl a\nd\n").map(|m| m[0].diffuse);
        assert_eq!(e.unwrap(), None, "a bare 'd' is skipped");
        assert!(parse(b"newmtl a\nKd 1 inf 0\n").is_err());
    }
}
