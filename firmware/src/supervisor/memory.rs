//! What the supervisor remembers of the springs across a reset: their heat estimate, their duty
//! history and their on-time counts.
//!
//! Nothing senses a spring, so after a reset the controller cannot see that a spring is hot.
//! `reset` (the console's) never clears this memory; a reset of the chip that keeps RAM (the
//! watchdog, a fault handler, the reset button) lets the board hand it back through
//! [`SpringMemory::to_words`] / [`SpringMemory::from_words`] (a magic word and a CRC, so RAM
//! that was never written, or was overwritten, is refused); a power-up, or memory that does
//! not check, starts from [`SpringMemory::POWER_UP`]: hot.

use crate::control::{OnTimer, SpringHeat};
use crate::outputs::SPRINGS;
use crate::settings::crc32;

/// The springs' memory (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringMemory {
    /// The heat estimate.
    pub heat: SpringHeat,
    /// Each spring's duty over the duty window, fraction.
    pub duty: [f32; SPRINGS],
    /// Each spring's continuous on-time count.
    pub on_time: [OnTimer; SPRINGS],
}

/// Words in [`SpringMemory::to_words`].
pub const MEMORY_WORDS: usize = 2 + 3 * SPRINGS + 2 * SPRINGS + 1;
const MEMORY_MAGIC: u32 = 0x5350_524D; // "SPRM"

impl SpringMemory {
    /// What a power-up assumes: every spring just austenite ([`SpringHeat::POWER_UP`]), its
    /// duty history at half its limit's default (the level below which a duty fault may be
    /// reset: the hottest state from which the controller lets a spring go again), and an
    /// on-time count of a spring switched off at that moment.
    pub const POWER_UP: SpringMemory = SpringMemory {
        heat: SpringHeat::POWER_UP,
        duty: [0.3; SPRINGS],
        on_time: [OnTimer::CLEAR; SPRINGS],
    };

    /// Every spring cold and rested: what a test bench or a simulator whose springs start at
    /// ambient hands a new supervisor.
    pub const RESTED: SpringMemory = SpringMemory {
        heat: SpringHeat::COLD,
        duty: [0.0; SPRINGS],
        on_time: [OnTimer::CLEAR; SPRINGS],
    };

    /// Encode into words for RAM kept across a reset (magic, a count, the values, a CRC-32).
    pub fn to_words(&self) -> [u32; MEMORY_WORDS] {
        let mut w = [0u32; MEMORY_WORDS];
        w[0] = MEMORY_MAGIC;
        let (h, aus) = self.heat.parts();
        w[1] = aus
            .iter()
            .enumerate()
            .fold(0, |b, (i, &a)| b | ((a as u32) << i));
        for i in 0..SPRINGS {
            w[2 + i] = h[i].to_bits();
            w[2 + SPRINGS + i] = self.duty[i].to_bits();
            w[2 + 2 * SPRINGS + i] = self.on_time[i].parts().0;
            w[2 + 3 * SPRINGS + i] = self.on_time[i].parts().1;
        }
        // The count shares the austenite word's upper half.
        w[1] |= (MEMORY_WORDS as u32) << 16;
        w[MEMORY_WORDS - 1] = Self::crc(&w[..MEMORY_WORDS - 1]);
        w
    }

    /// Decode words written by [`SpringMemory::to_words`]; `None` for anything else (RAM after
    /// a power-up, a damaged or foreign block, values out of range).
    pub fn from_words(w: &[u32; MEMORY_WORDS]) -> Option<SpringMemory> {
        if w[0] != MEMORY_MAGIC
            || w[1] >> 16 != MEMORY_WORDS as u32
            || Self::crc(&w[..MEMORY_WORDS - 1]) != w[MEMORY_WORDS - 1]
        {
            return None;
        }
        let mut h = [0.0; SPRINGS];
        let mut aus = [false; SPRINGS];
        let mut duty = [0.0; SPRINGS];
        let mut on_time = [OnTimer::CLEAR; SPRINGS];
        for i in 0..SPRINGS {
            h[i] = f32::from_bits(w[2 + i]);
            aus[i] = w[1] & (1 << i) != 0;
            duty[i] = f32::from_bits(w[2 + SPRINGS + i]);
            on_time[i] = OnTimer::from_parts(w[2 + 2 * SPRINGS + i], w[2 + 3 * SPRINGS + i]);
            if !(h[i].is_finite() && h[i] >= 0.0 && (0.0..=1.0).contains(&duty[i])) {
                return None;
            }
        }
        Some(SpringMemory {
            heat: SpringHeat::from_parts(h, aus),
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
    use crate::outputs::SpringMask;
    use crate::units::Seconds;

    #[test]
    fn words_round_trip_and_damage_is_refused() {
        let mut heat = SpringHeat::COLD;
        heat.update(
            SpringMask::from_bits(0b101),
            Seconds::lit(30.0),
            27.0,
            240.0,
        );
        let m = SpringMemory {
            heat,
            duty: [0.5, 0.0, 0.25],
            on_time: [
                OnTimer::from_parts(6000, 250),
                OnTimer::CLEAR,
                OnTimer::from_parts(100, 0),
            ],
        };
        let w = m.to_words();
        assert_eq!(SpringMemory::from_words(&w), Some(m));
        for i in 0..MEMORY_WORDS {
            for bit in [0, 7, 31] {
                let mut d = w;
                d[i] ^= 1 << bit;
                assert_eq!(SpringMemory::from_words(&d), None, "word {i} bit {bit}");
            }
        }
        assert_eq!(SpringMemory::from_words(&[0; MEMORY_WORDS]), None);
        assert_eq!(SpringMemory::from_words(&[u32::MAX; MEMORY_WORDS]), None);
    }
}
