//! Procedural terrain: the diamond-square algorithm with a map of regions (seed 002, "Terrain
//! LoD via ROAM"): corners seeded, then square and diamond midpoints set to the mean of their
//! neighbours plus a random perturbation that shrinks by the roughness factor at every level.
//! A map of region letters (`M` mountain, `H` hills, `P` plain, `W` water...) sets, per place,
//! the base height, the perturbation and the roughness; like the seed, the map is "sewn"
//! together by averaging: every sample blends its neighbouring map cells' parameters
//! bilinearly, so regions meet in smooth gradients instead of steps.
//!
//! Deterministic: the same parameters give the same heights on every machine (a counter-based
//! hash, not a stateful generator, decides each sample's perturbation).

use crate::dem::HeightGrid;

/// One kind of region: where the terrain sits and how rough it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Region {
    /// Base height, metres.
    pub base: f64,
    /// Perturbation of the first (coarsest) level, metres.
    pub amplitude: f64,
    /// Factor by which the perturbation shrinks from one level to the next (0..1; larger is
    /// rougher).
    pub roughness: f64,
}

impl Region {
    /// The region a map letter names (case-insensitive), `None` for an unknown letter.
    pub fn from_letter(c: char) -> Option<Region> {
        let (base, amplitude, roughness) = match c.to_ascii_uppercase() {
            'M' => (900.0, 1400.0, 0.58), // mountains: high, tall, rough
            'H' => (350.0, 500.0, 0.52),  // hills
            'P' => (80.0, 120.0, 0.45),   // plains: low and smooth
            'V' => (20.0, 200.0, 0.5),    // valleys
            'W' => (-40.0, 30.0, 0.4),    // water: a flat basin
            _ => return None,
        };
        Some(Region {
            base,
            amplitude,
            roughness,
        })
    }
}

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct TerrainParams {
    pub seed: u64,
    /// The grid is (2^levels + 1)² samples.
    pub levels: u32,
    /// Horizontal distance between samples, metres.
    pub spacing: f64,
    /// Multiplies every region's roughness (1 = as the regions say).
    pub roughness_scale: f64,
    /// Rows of region letters, all of one length; a single letter is a uniform terrain.
    pub regions: Vec<String>,
}

impl Default for TerrainParams {
    fn default() -> Self {
        TerrainParams {
            seed: 1,
            levels: 9,
            spacing: 30.0,
            roughness_scale: 1.0,
            regions: vec!["MH".into(), "PW".into()],
        }
    }
}

/// Why parameters cannot make a terrain.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TerrainError {
    #[error("levels must be in 1..=13 (a 2^levels + 1 grid), not {0}")]
    Levels(u32),
    #[error("the region map is empty or its rows differ in length")]
    MapShape,
    #[error(
        "unknown region letter {0:?} (known: M mountain, H hills, P plain, V valley, W water)"
    )]
    Letter(char),
    #[error("spacing {0} and roughness scale {1} must be finite and positive")]
    Scale(f64, f64),
}

/// A well-mixed 64-bit hash of (seed, x, y): the perturbation of one sample, in [−1, 1].
fn noise(seed: u64, x: usize, y: usize) -> f64 {
    let mut h = seed ^ (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (y as u64).rotate_left(32);
    h ^= h >> 33;
    h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    h ^= h >> 33;
    h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    h ^= h >> 33;
    (h >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Generates the terrain.
pub fn generate(params: &TerrainParams) -> Result<HeightGrid, TerrainError> {
    if !(1..=13).contains(&params.levels) {
        return Err(TerrainError::Levels(params.levels));
    }
    if !(params.spacing.is_finite()
        && params.spacing > 0.0
        && params.roughness_scale.is_finite()
        && params.roughness_scale > 0.0)
    {
        return Err(TerrainError::Scale(params.spacing, params.roughness_scale));
    }
    let map: Vec<Vec<Region>> = params
        .regions
        .iter()
        .map(|row| {
            row.chars()
                .map(|c| Region::from_letter(c).ok_or(TerrainError::Letter(c)))
                .collect()
        })
        .collect::<Result<_, _>>()?;
    let map_columns = map.first().map_or(0, Vec::len);
    if map_columns == 0 || map.iter().any(|r| r.len() != map_columns) {
        return Err(TerrainError::MapShape);
    }
    let n = (1usize << params.levels) + 1;
    // The region parameters of every sample: map cells are centred on a regular lattice over
    // the grid, blended bilinearly between neighbouring cell centres.
    let blend = |x: usize, y: usize| -> Region {
        let fx = (x as f64 / (n - 1) as f64 * map_columns as f64 - 0.5)
            .clamp(0.0, (map_columns - 1) as f64);
        let fy =
            (y as f64 / (n - 1) as f64 * map.len() as f64 - 0.5).clamp(0.0, (map.len() - 1) as f64);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(map_columns - 1), (y0 + 1).min(map.len() - 1));
        let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
        let mix = |f: fn(&Region) -> f64| {
            let top = f(&map[y0][x0]) * (1.0 - tx) + f(&map[y0][x1]) * tx;
            let bottom = f(&map[y1][x0]) * (1.0 - tx) + f(&map[y1][x1]) * tx;
            top * (1.0 - ty) + bottom * ty
        };
        Region {
            base: mix(|r| r.base),
            amplitude: mix(|r| r.amplitude),
            roughness: (mix(|r| r.roughness) * params.roughness_scale).min(0.95),
        }
    };
    let regions: Vec<Region> = (0..n * n).map(|i| blend(i % n, i / n)).collect();
    // The fractal part, around 0; the bases are added at the end.
    let mut h = vec![0.0f64; n * n];
    for &(x, y) in &[(0, 0), (n - 1, 0), (0, n - 1), (n - 1, n - 1)] {
        h[y * n + x] = noise(params.seed, x, y) * regions[y * n + x].amplitude;
    }
    let perturbation = |x: usize, y: usize, level: u32| {
        let r = &regions[y * n + x];
        noise(params.seed, x, y) * r.amplitude * r.roughness.powi(level as i32)
    };
    let mut step = n - 1;
    let mut level = 1;
    while step > 1 {
        let half = step / 2;
        // Square step: the centre of each square.
        for y in (half..n).step_by(step) {
            for x in (half..n).step_by(step) {
                let mean = (h[(y - half) * n + x - half]
                    + h[(y - half) * n + x + half]
                    + h[(y + half) * n + x - half]
                    + h[(y + half) * n + x + half])
                    / 4.0;
                h[y * n + x] = mean + perturbation(x, y, level);
            }
        }
        // Diamond step: the midpoints of the squares' edges, from their 3 or 4 neighbours.
        for y in (0..n).step_by(half) {
            let start = if (y / half).is_multiple_of(2) {
                half
            } else {
                0
            };
            for x in (start..n).step_by(step) {
                let mut sum = 0.0;
                let mut count = 0.0;
                for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                    let (nx, ny) = (x as i64 + dx * half as i64, y as i64 + dy * half as i64);
                    if (0..n as i64).contains(&nx) && (0..n as i64).contains(&ny) {
                        sum += h[ny as usize * n + nx as usize];
                        count += 1.0;
                    }
                }
                h[y * n + x] = sum / count + perturbation(x, y, level);
            }
        }
        step = half;
        level += 1;
    }
    let heights = h
        .iter()
        .zip(&regions)
        .map(|(v, r)| (v + r.base) as f32)
        .collect();
    Ok(HeightGrid {
        spacing: [params.spacing, params.spacing],
        ..HeightGrid::unit(n, n, heights)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(levels: u32, regions: &[&str]) -> TerrainParams {
        TerrainParams {
            levels,
            regions: regions.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        }
    }

    /// Mean absolute difference between horizontal neighbours: how rough a terrain is.
    fn roughness(g: &HeightGrid, rows: std::ops::Range<usize>) -> f64 {
        let n = g.columns;
        let mut sum = 0.0;
        let mut count = 0.0;
        for y in rows {
            for x in 0..n - 1 {
                sum += (g.heights[y * n + x + 1] - g.heights[y * n + x]).abs() as f64;
                count += 1.0;
            }
        }
        sum / count
    }

    #[test]
    fn deterministic_and_seed_dependent() {
        let a = generate(&params(6, &["M"])).unwrap();
        assert_eq!(a, generate(&params(6, &["M"])).unwrap());
        assert_eq!((a.columns, a.rows), (65, 65));
        assert!(a.heights.iter().all(|h| h.is_finite()));
        let b = generate(&TerrainParams {
            seed: 2,
            ..params(6, &["M"])
        })
        .unwrap();
        assert_ne!(a.heights, b.heights);
    }

    #[test]
    fn regions_set_height_and_roughness() {
        // Mountains on the top half of the map, plains on the bottom.
        let g = generate(&params(7, &["M", "P"])).unwrap();
        let n = g.columns;
        let mean = |rows: std::ops::Range<usize>| {
            let v: Vec<f32> = rows
                .flat_map(|y| g.heights[y * n..(y + 1) * n].to_vec())
                .collect();
            v.iter().sum::<f32>() / v.len() as f32
        };
        assert!(
            mean(0..n / 5) > mean(4 * n / 5..n) + 300.0,
            "mountains stand higher"
        );
        assert!(
            roughness(&g, 0..n / 5) > 2.0 * roughness(&g, 4 * n / 5..n),
            "and rougher"
        );
        // Roughness scale: a smoother terrain when lowered.
        let smooth = generate(&TerrainParams {
            roughness_scale: 0.5,
            ..params(7, &["H"])
        })
        .unwrap();
        let rough = generate(&params(7, &["H"])).unwrap();
        assert!(roughness(&smooth, 0..n) < roughness(&rough, 0..n));
    }

    #[test]
    fn bad_parameters_are_errors() {
        assert_eq!(generate(&params(0, &["M"])), Err(TerrainError::Levels(0)));
        assert_eq!(generate(&params(14, &["M"])), Err(TerrainError::Levels(14)));
        assert_eq!(
            generate(&params(4, &["MX"])),
            Err(TerrainError::Letter('X'))
        );
        assert_eq!(
            generate(&params(4, &["MM", "M"])),
            Err(TerrainError::MapShape)
        );
        assert_eq!(generate(&params(4, &[])), Err(TerrainError::MapShape));
        assert!(generate(&TerrainParams {
            spacing: 0.0,
            ..params(4, &["M"])
        })
        .is_err());
    }
}
