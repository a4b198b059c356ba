//! Simplex keys packed in 16 bytes for the build's per-simplex tables (the finished
//! patches' index, the live patches' index and set): a [`SimplexKey`] takes 32 (a u128 path,
//! 16-aligned), and at 100 M input triangles these tables hold 0.8 to 1.6 M keys each.

use tessera_core::leb::SimplexKey;

/// A [`SimplexKey`] in 16 bytes (4-aligned, most significant word first): the root above
/// bit 125, a marker bit at the simplex's level and the path below it, ordered as the keys
/// are (root, level, path).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct PackedKey(pub(crate) [u32; 4]);

impl PackedKey {
    /// The packed key, or `None` for a key no hierarchy makes (a root past 7, a level past
    /// 124 — the lattice's 30 bits an axis allow 90 — or path bits past the level).
    pub(crate) fn of(key: SimplexKey) -> Option<PackedKey> {
        let fits = key.root < 8 && key.level <= 124 && key.path >> key.level == 0;
        let packed = (key.root as u128) << 125 | 1u128 << key.level | key.path;
        fits.then_some(PackedKey(
            [96, 64, 32, 0].map(|shift| (packed >> shift) as u32),
        ))
    }

    /// The packed key these words are, if they are one (they hold a level's marker bit).
    pub(crate) fn from_words(words: [u32; 4]) -> Option<PackedKey> {
        let packed = words.iter().fold(0u128, |acc, &w| acc << 32 | w as u128);
        (packed & ((1u128 << 125) - 1) != 0).then_some(PackedKey(words))
    }

    /// `key` packed, for a key of a hierarchy (every one is: a bug otherwise).
    pub(crate) fn of_hierarchy(key: SimplexKey) -> PackedKey {
        PackedKey::of(key).unwrap_or_else(|| panic!("simplex {key:?} is outside every hierarchy"))
    }

    pub(crate) fn key(self) -> SimplexKey {
        let packed = self.0.iter().fold(0u128, |acc, &w| acc << 32 | w as u128);
        let root = (packed >> 125) as u8;
        let below = packed & ((1u128 << 125) - 1);
        let level = 127 - below.leading_zeros() as u16;
        SimplexKey {
            root,
            level,
            path: below ^ (1u128 << level),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn key(root: u8, level: u16, path: u128) -> SimplexKey {
        let path = if level == 0 {
            0
        } else {
            path & (u128::MAX >> (128 - level))
        };
        SimplexKey { root, level, path }
    }

    proptest! {
        #[test]
        fn packed_keys_round_trip_and_sort_as_keys_do(
            a in (0u8..8, 0u16..=124, any::<u128>()),
            b in (0u8..8, 0u16..=124, any::<u128>()),
        ) {
            let (a, b) = (key(a.0, a.1, a.2), key(b.0, b.1, b.2));
            let (pa, pb) = (PackedKey::of(a).unwrap(), PackedKey::of(b).unwrap());
            prop_assert_eq!(pa.key(), a);
            prop_assert_eq!(pa.cmp(&pb), a.cmp(&b));
            prop_assert_eq!(PackedKey::from_words(pa.0), Some(pa));
        }
    }

    #[test]
    fn keys_no_hierarchy_makes_are_refused() {
        assert!(PackedKey::of(key(8, 3, 1)).is_none());
        assert!(PackedKey::of(key(0, 125, 1)).is_none());
        assert!(PackedKey::of(SimplexKey {
            root: 0,
            level: 2,
            path: 4
        })
        .is_none());
        assert!(PackedKey::of(key(7, 124, u128::MAX)).is_some());
        // Words without a marker bit (any other pattern is a key: a root, a level ≤ 124).
        assert!(PackedKey::from_words([0xe000_0000, 0, 0, 0]).is_none());
        assert!(PackedKey::from_words([0xf000_0000, 0, 0, 0]).is_some());
    }
}
