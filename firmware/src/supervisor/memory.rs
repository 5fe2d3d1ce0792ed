//! What the supervisor remembers of the springs across a reset: the observer's estimate of
//! each spring (temperature and austenite fraction), their duty history and their on-time
//! counts.
//!
//! Nothing senses a spring, so after a reset the controller cannot see that a spring is hot.
//! `reset` (the console's) never clears this memory; a reset of the chip that keeps RAM (the
//! watchdog, a fault handler, the reset button) lets the board hand it back through
//! [`SpringMemory::to_words`] / [`SpringMemory::from_words`] (a magic word and a CRC, so RAM
//! that was never written, or was overwritten, is refused); a power-up, or memory that does
//! not check, starts from [`SpringMemory::POWER_UP`]: hot.

use crate::control::OnTimer;
use crate::observer::SpringState;
use crate::outputs::SPRINGS;
use crate::settings::{SPRING_HOT_K, crc32};

/// One spring's remembered estimate: temperature, K, and austenite fraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringRecord {
    /// Temperature, K.
    pub temp_k: f32,
    /// Austenite fraction, 0…1.
    pub austenite: f32,
}

impl SpringRecord {
    /// The record of an observer's spring state.
    pub fn of(s: &SpringState) -> SpringRecord {
        SpringRecord {
            temp_k: s.temp_k,
            austenite: s.austenite,
        }
    }
}

/// The springs' memory (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringMemory {
    /// Each spring's estimate; `None`: the springs are at the ambient, martensite (the
    /// observer places them at the first measured ambient).
    pub springs: Option<[SpringRecord; SPRINGS]>,
    /// Each spring's duty over the duty window, fraction.
    pub duty: [f32; SPRINGS],
    /// Each spring's continuous on-time count.
    pub on_time: [OnTimer; SPRINGS],
}

/// Words in [`SpringMemory::to_words`].
pub const MEMORY_WORDS: usize = 2 + 2 * SPRINGS + SPRINGS + 2 * SPRINGS + 1;
const MEMORY_MAGIC: u32 = 0x5350_524E; // "SPRN"

impl SpringMemory {
    /// What a power-up assumes: every spring hot and austenite (at `spring_hot_k`'s default:
    /// a spring may have been driven until the moment the power went), its duty history at
    /// half its limit's default (the level below which a duty fault may be reset: the hottest
    /// state from which the controller lets a spring go again), and an on-time count of a
    /// spring switched off at that moment.
    pub const POWER_UP: SpringMemory = SpringMemory {
        springs: Some(
            [SpringRecord {
                temp_k: SPRING_HOT_K,
                austenite: 1.0,
            }; SPRINGS],
        ),
        duty: [0.3; SPRINGS],
        on_time: [OnTimer::CLEAR; SPRINGS],
    };

    /// Every spring at the ambient and rested: what a test bench or a simulator whose springs
    /// start at ambient hands a new supervisor.
    pub const RESTED: SpringMemory = SpringMemory {
        springs: None,
        duty: [0.0; SPRINGS],
        on_time: [OnTimer::CLEAR; SPRINGS],
    };

    /// Encode into words for RAM kept across a reset (magic, a count and the at-ambient flag,
    /// the values, a CRC-32).
    pub fn to_words(&self) -> [u32; MEMORY_WORDS] {
        let mut w = [0u32; MEMORY_WORDS];
        w[0] = MEMORY_MAGIC;
        w[1] = ((MEMORY_WORDS as u32) << 16) | self.springs.is_none() as u32;
        let springs = self.springs.unwrap_or(
            [SpringRecord {
                temp_k: 0.0,
                austenite: 0.0,
            }; SPRINGS],
        );
        for i in 0..SPRINGS {
            w[2 + i] = springs[i].temp_k.to_bits();
            w[2 + SPRINGS + i] = springs[i].austenite.to_bits();
            w[2 + 2 * SPRINGS + i] = self.duty[i].to_bits();
            w[2 + 3 * SPRINGS + i] = self.on_time[i].parts().0;
            w[2 + 4 * SPRINGS + i] = self.on_time[i].parts().1;
        }
        w[MEMORY_WORDS - 1] = Self::crc(&w[..MEMORY_WORDS - 1]);
        w
    }

    /// Decode words written by [`SpringMemory::to_words`]; `None` for anything else (RAM after
    /// a power-up, a damaged or foreign block, values out of range).
    pub fn from_words(w: &[u32; MEMORY_WORDS]) -> Option<SpringMemory> {
        if w[0] != MEMORY_MAGIC
            || w[1] >> 16 != MEMORY_WORDS as u32
            || w[1] & 0xFFFE != 0
            || Self::crc(&w[..MEMORY_WORDS - 1]) != w[MEMORY_WORDS - 1]
        {
            return None;
        }
        let at_ambient = w[1] & 1 == 1;
        let mut springs = [SpringRecord {
            temp_k: 0.0,
            austenite: 0.0,
        }; SPRINGS];
        let mut duty = [0.0; SPRINGS];
        let mut on_time = [OnTimer::CLEAR; SPRINGS];
        for i in 0..SPRINGS {
            let t = f32::from_bits(w[2 + i]);
            let a = f32::from_bits(w[2 + SPRINGS + i]);
            duty[i] = f32::from_bits(w[2 + 2 * SPRINGS + i]);
            on_time[i] = OnTimer::from_parts(w[2 + 3 * SPRINGS + i], w[2 + 4 * SPRINGS + i]);
            let spring_ok = at_ambient || (t.is_finite() && t > 0.0 && (0.0..=1.0).contains(&a));
            if !(spring_ok && (0.0..=1.0).contains(&duty[i])) {
                return None;
            }
            springs[i] = SpringRecord {
                temp_k: t,
                austenite: a,
            };
        }
        Some(SpringMemory {
            springs: (!at_ambient).then_some(springs),
            duty,
            on_time,
        })
    }

    fn crc(words: &[u32]) -> u32 {
        words.iter().fold(0, |c, w| crc32(c, &w.to_le_bytes()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_round_trip_and_damage_is_refused() {
        let m = SpringMemory {
            springs: Some([
                SpringRecord {
                    temp_k: 352.5,
                    austenite: 0.75,
                },
                SpringRecord {
                    temp_k: 300.0,
                    austenite: 0.0,
                },
                SpringRecord {
                    temp_k: 330.0,
                    austenite: 1.0,
                },
            ]),
            duty: [0.5, 0.0, 0.25],
            on_time: [
                OnTimer::from_parts(6000, 250),
                OnTimer::CLEAR,
                OnTimer::from_parts(100, 0),
            ],
        };
        for m in [m, SpringMemory::RESTED, SpringMemory::POWER_UP] {
            let w = m.to_words();
            assert_eq!(SpringMemory::from_words(&w), Some(m));
            for i in 0..MEMORY_WORDS {
                for bit in [0, 7, 31] {
                    let mut d = w;
                    d[i] ^= 1 << bit;
                    assert_eq!(SpringMemory::from_words(&d), None, "word {i} bit {bit}");
                }
            }
        }
        assert_eq!(SpringMemory::from_words(&[0; MEMORY_WORDS]), None);
        assert_eq!(SpringMemory::from_words(&[u32::MAX; MEMORY_WORDS]), None);
    }
}
