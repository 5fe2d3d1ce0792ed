//! MLX90640 EEPROM images: the coded fields, their exact encoding, and a realistic sensor.
//!
//! This module owns the bit layout of the 832 EEPROM words (0x2400–0x273F) as the firmware's
//! calibration extraction reads it (datasheet Rev. 12 §11.1, reference library
//! `MLX90640_ExtractParameters`, ported in `thermorph::mlx90640::Calibration`), and the
//! simulator's synthetic sensors:
//!
//! - [`EepromFields`] holds every coded field as the integer the EEPROM stores, plus the bits
//!   the extraction ignores, so that [`EepromFields::decode`] and [`EepromFields::encode`] are
//!   exact inverses: words → fields → words is the identity for any 832 words, and fields →
//!   words → fields for any fields within their bit widths ([`EepromFields::validate`]).
//! - [`realistic`] returns the fields of a plausible MLX90640BAB (55° field of view): the
//!   global words of the datasheet's worked example, a sensitivity map with mild vignetting
//!   (every pixel's alpha about 1.0–1.3·10⁻⁷, the datasheet example's magnitude) and a seeded
//!   spread of offset, sensitivity, Kta and Kv.
//!
//! Word offsets below count from 0x2400 (`ee[16]` is 0x2410); "row" and "column" are 0-based.
//!
//! This module owns the error type of fields that do not encode, [`EepromError`].

use thermorph::mlx90640::{COLS, EEPROM_WORDS, PIXELS, ROWS};

/// Every coded EEPROM field, as the integer the EEPROM stores (signed fields as signed
/// integers of their bit width), plus the bits the extraction ignores.
///
/// Row/column-parity tables (`kv_t`, `kta_rc`) are indexed as the library's
/// `2·(row mod 2) + (column mod 2)`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EepromFields {
    /// The words and bits the extraction ignores, in place (all of 0x2400–0x240F but bit 11
    /// of 0x240A, and bits 14–15 of 0x2438 and 0x243F); zero elsewhere. Kept so that decoding
    /// and encoding are exact inverses.
    pub reserved: [u16; EEPROM_WORDS],
    /// 0x240A bit 11: `false` = calibrated in chess mode, `true` = interleaved.
    pub interleaved_calibration: bool,
    /// 0x2410 bits 12–15: Alpha_PTAT = code/4 + 8.
    pub alpha_ptat_code: u8,
    /// 0x2410 bits 8–11: offset row scale (log2).
    pub occ_row_scale: u8,
    /// 0x2410 bits 4–7: offset column scale (log2).
    pub occ_column_scale: u8,
    /// 0x2410 bits 0–3: offset remnant scale (log2).
    pub occ_rem_scale: u8,
    /// 0x2411: offset reference, LSB.
    pub offset_ref: i16,
    /// 0x2412–0x2417: offset row corrections (4-bit signed, nibbles from the low end).
    pub occ_row: [i8; ROWS],
    /// 0x2418–0x241F: offset column corrections (4-bit signed).
    pub occ_column: [i8; COLS],
    /// 0x2420 bits 12–15: alpha scale − 30 (the CP alpha scale is this + 27).
    pub alpha_scale_code: u8,
    /// 0x2420 bits 8–11: alpha row scale (log2).
    pub acc_row_scale: u8,
    /// 0x2420 bits 4–7: alpha column scale (log2).
    pub acc_column_scale: u8,
    /// 0x2420 bits 0–3: alpha remnant scale (log2).
    pub acc_rem_scale: u8,
    /// 0x2421: alpha reference (unsigned).
    pub alpha_ref: u16,
    /// 0x2422–0x2427: alpha row corrections (4-bit signed).
    pub acc_row: [i8; ROWS],
    /// 0x2428–0x242F: alpha column corrections (4-bit signed).
    pub acc_column: [i8; COLS],
    /// 0x2430: gain reference GAIN (signed 16 bit).
    pub gain: i16,
    /// 0x2431: PTAT at 25 °C, V_PTAT25.
    pub v_ptat25: u16,
    /// 0x2432 bits 10–15: K_V_PTAT·4096 (6-bit signed).
    pub kv_ptat: i8,
    /// 0x2432 bits 0–9: K_T_PTAT·8 (10-bit signed).
    pub kt_ptat: i16,
    /// 0x2433 high byte: K_Vdd/32 (signed byte).
    pub k_vdd: i8,
    /// 0x2433 low byte: VDD_25 coded as (VDD_25 + 8192)/32 + 256 (unsigned byte).
    pub vdd25: u8,
    /// 0x2434: Kv·2^`kv_scale` by row/column parity (4-bit signed), from nibbles 4, 2, 3, 1
    /// (bits 12–15, 4–7, 8–11, 0–3).
    pub kv_t: [i8; 4],
    /// 0x2435 bits 0–5: IL_CHESS_C1·16 (6-bit signed).
    pub il_chess_c1: i8,
    /// 0x2435 bits 6–10: IL_CHESS_C2·2 (5-bit signed).
    pub il_chess_c2: i8,
    /// 0x2435 bits 11–15: IL_CHESS_C3·8 (5-bit signed).
    pub il_chess_c3: i8,
    /// 0x2436/0x2437: Kta by row/column parity, scaled by 2^(`kta_scale1_code` + 8), from the
    /// bytes 0x2436 high, 0x2437 high, 0x2436 low, 0x2437 low (signed bytes).
    pub kta_rc: [i8; 4],
    /// 0x2438 bits 12–13: ADC resolution at calibration (0–3 for 16–19 bit).
    pub resolution: u8,
    /// 0x2438 bits 8–11: Kv scale (log2).
    pub kv_scale: u8,
    /// 0x2438 bits 4–7: Kta scale 1 − 8 (log2).
    pub kta_scale1_code: u8,
    /// 0x2438 bits 0–3: Kta remnant scale, "Kta scale 2" (log2).
    pub kta_scale2: u8,
    /// 0x2439 bits 0–9: CP subpage-0 alpha·2^(`alpha_scale_code` + 27) (10-bit signed).
    pub cp_alpha0: i16,
    /// 0x2439 bits 10–15: CP subpage-1/subpage-0 alpha ratio·128 − 128 (6-bit signed).
    pub cp_alpha_ratio: i8,
    /// 0x243A bits 0–9: CP subpage-0 offset, LSB (10-bit signed).
    pub cp_offset0: i16,
    /// 0x243A bits 10–15: CP subpage-1 offset − subpage-0 offset, LSB (6-bit signed).
    pub cp_offset_delta: i8,
    /// 0x243B low byte: K_Ta_CP·2^(`kta_scale1_code` + 8) (signed byte).
    pub cp_kta: i8,
    /// 0x243B high byte: K_V_CP·2^`kv_scale` (signed byte).
    pub cp_kv: i8,
    /// 0x243C low byte: TGC·32 (signed byte).
    pub tgc: i8,
    /// 0x243C high byte: KsTa·8192 (signed byte).
    pub ks_ta: i8,
    /// 0x243D low/high, 0x243E low/high: KsTo of ranges 1–4 · 2^(`ks_to_scale` + 8) (signed
    /// bytes); range 5 is fixed at −0.0002 by the library.
    pub ks_to: [i8; 4],
    /// 0x243F bits 12–13: corner-temperature step code (step = code·10 °C).
    pub ct_step: u8,
    /// 0x243F bits 8–11: CT4 − CT3 in steps.
    pub ct4: u8,
    /// 0x243F bits 4–7: CT3 in steps.
    pub ct3: u8,
    /// 0x243F bits 0–3: KsTo scale − 8 (log2).
    pub ks_to_scale: u8,
    /// Per pixel (word 0x2440 + p): the whole word is 0, a broken pixel. A broken pixel's other
    /// per-pixel fields must be zero and its outlier flag clear.
    pub broken: [bool; PIXELS],
    /// Per pixel bits 10–15: offset remnant (6-bit signed).
    pub offset_delta: [i8; PIXELS],
    /// Per pixel bits 4–9: alpha remnant (6-bit signed).
    pub alpha_delta: [i8; PIXELS],
    /// Per pixel bits 1–3: Kta remnant (3-bit signed).
    pub kta_delta: [i8; PIXELS],
    /// Per pixel bit 0: outlier flag.
    pub outlier: [bool; PIXELS],
}

/// Two's complement of the low `bits` bits of `v`.
fn sx(v: u16, bits: u32) -> i16 {
    let v = v as i32 & ((1 << bits) - 1);
    (if v >= 1 << (bits - 1) {
        v - (1 << bits)
    } else {
        v
    }) as i16
}

/// The low `bits` bits of `v` (two's complement for negative `v`).
fn ux(v: i64, bits: u32) -> u16 {
    (v & ((1i64 << bits) - 1)) as u16
}

/// Signed 4-bit nibbles of consecutive words, low nibble first (the library's tables).
fn nibbles<const N: usize>(w: &[u16]) -> [i8; N] {
    std::array::from_fn(|i| sx(w[i / 4] >> (4 * (i % 4)), 4) as i8)
}

/// OR signed 4-bit values into consecutive words, low nibble first.
fn put_nibbles(w: &mut [u16], v: &[i8]) {
    for (i, &x) in v.iter().enumerate() {
        w[i / 4] |= ux(x as i64, 4) << (4 * (i % 4));
    }
}

/// Mask of the bits of word `i` the extraction reads; the rest is reserved.
fn used_mask(i: usize) -> u16 {
    match i {
        10 => 0x0800,
        0..=15 => 0,
        56 | 63 => 0x3FFF,
        _ => 0xFFFF,
    }
}

/// EEPROM fields that do not encode; `Display` names the first offending field.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EepromError {
    /// A field's value does not fit its bit width.
    #[error("EEPROM field {field} = {value} does not fit {bits} bits ({lo}..={hi})")]
    Width {
        /// The field (`kv_t[2]`).
        field: String,
        /// Its value.
        value: i64,
        /// Its width, bits.
        bits: u32,
        /// The smallest value that fits.
        lo: i64,
        /// The largest value that fits.
        hi: i64,
    },
    /// A reserved word's bits overlap the coded bits of that word.
    #[error("EEPROM field reserved[{index}] = 0x{value:04X} overlaps coded bits 0x{coded:04X}")]
    Reserved {
        /// The word's index.
        index: usize,
        /// The reserved bits given.
        value: u16,
        /// The word's coded bits.
        coded: u16,
    },
    /// A broken pixel (word 0) with deltas or an outlier flag.
    #[error(
        "EEPROM field broken[{0}] is set (pixel word 0) but the pixel's deltas or outlier flag \
         are not zero"
    )]
    BrokenNotZero(usize),
    /// A pixel not marked broken whose word would be 0.
    #[error(
        "EEPROM field broken[{0}] is clear but the pixel word would be 0 (a broken pixel): set a \
         delta or the outlier flag"
    )]
    ZeroWord(usize),
}

/// Check that `v` fits a `bits`-bit signed (or unsigned) field called `name`.
fn check(name: &str, v: i64, bits: u32, signed: bool) -> Result<(), EepromError> {
    let (lo, hi) = if signed {
        (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1)
    } else {
        (0, (1i64 << bits) - 1)
    };
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(EepromError::Width {
            field: name.to_string(),
            value: v,
            bits,
            lo,
            hi,
        })
    }
}

impl EepromFields {
    /// Split 832 EEPROM words into fields (total: every input decodes, and
    /// [`EepromFields::encode`] gives the same words back).
    pub fn decode(w: &[u16; EEPROM_WORDS]) -> Self {
        let reserved = std::array::from_fn(|i| w[i] & !used_mask(i));
        let px = |p: usize| w[64 + p];
        EepromFields {
            reserved,
            interleaved_calibration: w[10] & 0x0800 != 0,
            alpha_ptat_code: (w[16] >> 12) as u8,
            occ_row_scale: ((w[16] >> 8) & 15) as u8,
            occ_column_scale: ((w[16] >> 4) & 15) as u8,
            occ_rem_scale: (w[16] & 15) as u8,
            offset_ref: w[17] as i16,
            occ_row: nibbles(&w[18..24]),
            occ_column: nibbles(&w[24..32]),
            alpha_scale_code: (w[32] >> 12) as u8,
            acc_row_scale: ((w[32] >> 8) & 15) as u8,
            acc_column_scale: ((w[32] >> 4) & 15) as u8,
            acc_rem_scale: (w[32] & 15) as u8,
            alpha_ref: w[33],
            acc_row: nibbles(&w[34..40]),
            acc_column: nibbles(&w[40..48]),
            gain: w[48] as i16,
            v_ptat25: w[49],
            kv_ptat: sx(w[50] >> 10, 6) as i8,
            kt_ptat: sx(w[50], 10),
            k_vdd: (w[51] >> 8) as u8 as i8,
            vdd25: (w[51] & 0xFF) as u8,
            kv_t: [
                sx(w[52] >> 12, 4) as i8,
                sx(w[52] >> 4, 4) as i8,
                sx(w[52] >> 8, 4) as i8,
                sx(w[52], 4) as i8,
            ],
            il_chess_c1: sx(w[53], 6) as i8,
            il_chess_c2: sx(w[53] >> 6, 5) as i8,
            il_chess_c3: sx(w[53] >> 11, 5) as i8,
            kta_rc: [
                (w[54] >> 8) as u8 as i8,
                (w[55] >> 8) as u8 as i8,
                (w[54] & 0xFF) as u8 as i8,
                (w[55] & 0xFF) as u8 as i8,
            ],
            resolution: ((w[56] >> 12) & 3) as u8,
            kv_scale: ((w[56] >> 8) & 15) as u8,
            kta_scale1_code: ((w[56] >> 4) & 15) as u8,
            kta_scale2: (w[56] & 15) as u8,
            cp_alpha0: sx(w[57], 10),
            cp_alpha_ratio: sx(w[57] >> 10, 6) as i8,
            cp_offset0: sx(w[58], 10),
            cp_offset_delta: sx(w[58] >> 10, 6) as i8,
            cp_kta: (w[59] & 0xFF) as u8 as i8,
            cp_kv: (w[59] >> 8) as u8 as i8,
            tgc: (w[60] & 0xFF) as u8 as i8,
            ks_ta: (w[60] >> 8) as u8 as i8,
            ks_to: [
                (w[61] & 0xFF) as u8 as i8,
                (w[61] >> 8) as u8 as i8,
                (w[62] & 0xFF) as u8 as i8,
                (w[62] >> 8) as u8 as i8,
            ],
            ct_step: ((w[63] >> 12) & 3) as u8,
            ct4: ((w[63] >> 8) & 15) as u8,
            ct3: ((w[63] >> 4) & 15) as u8,
            ks_to_scale: (w[63] & 15) as u8,
            broken: std::array::from_fn(|p| px(p) == 0),
            offset_delta: std::array::from_fn(|p| sx(px(p) >> 10, 6) as i8),
            alpha_delta: std::array::from_fn(|p| sx(px(p) >> 4, 6) as i8),
            kta_delta: std::array::from_fn(|p| sx(px(p) >> 1, 3) as i8),
            outlier: std::array::from_fn(|p| px(p) & 1 != 0),
        }
    }

    /// Check every field against its bit width, the reserved bits against the coded ones and
    /// the broken flags against the pixel words; the error names the first offending field.
    pub fn validate(&self) -> Result<(), EepromError> {
        for (i, &r) in self.reserved.iter().enumerate() {
            if r & used_mask(i) != 0 {
                return Err(EepromError::Reserved {
                    index: i,
                    value: r,
                    coded: used_mask(i),
                });
            }
        }
        for (name, v, bits) in [
            ("alpha_ptat_code", self.alpha_ptat_code, 4),
            ("occ_row_scale", self.occ_row_scale, 4),
            ("occ_column_scale", self.occ_column_scale, 4),
            ("occ_rem_scale", self.occ_rem_scale, 4),
            ("alpha_scale_code", self.alpha_scale_code, 4),
            ("acc_row_scale", self.acc_row_scale, 4),
            ("acc_column_scale", self.acc_column_scale, 4),
            ("acc_rem_scale", self.acc_rem_scale, 4),
            ("resolution", self.resolution, 2),
            ("kv_scale", self.kv_scale, 4),
            ("kta_scale1_code", self.kta_scale1_code, 4),
            ("kta_scale2", self.kta_scale2, 4),
            ("ct_step", self.ct_step, 2),
            ("ct4", self.ct4, 4),
            ("ct3", self.ct3, 4),
            ("ks_to_scale", self.ks_to_scale, 4),
        ] {
            check(name, v as i64, bits, false)?;
        }
        for (name, table) in [
            ("occ_row", &self.occ_row[..]),
            ("occ_column", &self.occ_column[..]),
            ("acc_row", &self.acc_row[..]),
            ("acc_column", &self.acc_column[..]),
            ("kv_t", &self.kv_t[..]),
        ] {
            for (k, &v) in table.iter().enumerate() {
                check(&format!("{name}[{k}]"), v as i64, 4, true)?;
            }
        }
        for (name, v, bits) in [
            ("kv_ptat", self.kv_ptat as i16, 6),
            ("kt_ptat", self.kt_ptat, 10),
            ("il_chess_c1", self.il_chess_c1 as i16, 6),
            ("il_chess_c2", self.il_chess_c2 as i16, 5),
            ("il_chess_c3", self.il_chess_c3 as i16, 5),
            ("cp_alpha0", self.cp_alpha0, 10),
            ("cp_alpha_ratio", self.cp_alpha_ratio as i16, 6),
            ("cp_offset0", self.cp_offset0, 10),
            ("cp_offset_delta", self.cp_offset_delta as i16, 6),
        ] {
            check(name, v as i64, bits, true)?;
        }
        for p in 0..PIXELS {
            if self.broken[p] {
                if self.offset_delta[p] != 0
                    || self.alpha_delta[p] != 0
                    || self.kta_delta[p] != 0
                    || self.outlier[p]
                {
                    return Err(EepromError::BrokenNotZero(p));
                }
                continue;
            }
            check(
                &format!("offset_delta[{p}]"),
                self.offset_delta[p] as i64,
                6,
                true,
            )?;
            check(
                &format!("alpha_delta[{p}]"),
                self.alpha_delta[p] as i64,
                6,
                true,
            )?;
            check(
                &format!("kta_delta[{p}]"),
                self.kta_delta[p] as i64,
                3,
                true,
            )?;
            if self.pixel_word(p) == 0 {
                return Err(EepromError::ZeroWord(p));
            }
        }
        Ok(())
    }

    /// Mark pixel `p` broken: its word becomes 0, so its deltas and outlier flag are cleared.
    pub fn mark_broken(&mut self, p: usize) {
        self.broken[p] = true;
        self.offset_delta[p] = 0;
        self.alpha_delta[p] = 0;
        self.kta_delta[p] = 0;
        self.outlier[p] = false;
    }

    /// Pixel `p`'s EEPROM word (fields assumed in range).
    fn pixel_word(&self, p: usize) -> u16 {
        if self.broken[p] {
            return 0;
        }
        (ux(self.offset_delta[p] as i64, 6) << 10)
            | (ux(self.alpha_delta[p] as i64, 6) << 4)
            | (ux(self.kta_delta[p] as i64, 3) << 1)
            | self.outlier[p] as u16
    }

    /// Join the fields into 832 EEPROM words, or name the first field that does not fit
    /// ([`EepromFields::validate`]).
    pub fn encode(&self) -> Result<[u16; EEPROM_WORDS], EepromError> {
        self.validate()?;
        let mut w = self.reserved;
        if self.interleaved_calibration {
            w[10] |= 0x0800;
        }
        w[16] = (self.alpha_ptat_code as u16) << 12
            | (self.occ_row_scale as u16) << 8
            | (self.occ_column_scale as u16) << 4
            | self.occ_rem_scale as u16;
        w[17] = self.offset_ref as u16;
        put_nibbles(&mut w[18..24], &self.occ_row);
        put_nibbles(&mut w[24..32], &self.occ_column);
        w[32] = (self.alpha_scale_code as u16) << 12
            | (self.acc_row_scale as u16) << 8
            | (self.acc_column_scale as u16) << 4
            | self.acc_rem_scale as u16;
        w[33] = self.alpha_ref;
        put_nibbles(&mut w[34..40], &self.acc_row);
        put_nibbles(&mut w[40..48], &self.acc_column);
        w[48] = self.gain as u16;
        w[49] = self.v_ptat25;
        w[50] = ux(self.kv_ptat as i64, 6) << 10 | ux(self.kt_ptat as i64, 10);
        w[51] = (self.k_vdd as u8 as u16) << 8 | self.vdd25 as u16;
        w[52] = ux(self.kv_t[0] as i64, 4) << 12
            | ux(self.kv_t[2] as i64, 4) << 8
            | ux(self.kv_t[1] as i64, 4) << 4
            | ux(self.kv_t[3] as i64, 4);
        w[53] = ux(self.il_chess_c1 as i64, 6)
            | ux(self.il_chess_c2 as i64, 5) << 6
            | ux(self.il_chess_c3 as i64, 5) << 11;
        w[54] = (self.kta_rc[0] as u8 as u16) << 8 | self.kta_rc[2] as u8 as u16;
        w[55] = (self.kta_rc[1] as u8 as u16) << 8 | self.kta_rc[3] as u8 as u16;
        w[56] |= (self.resolution as u16) << 12
            | (self.kv_scale as u16) << 8
            | (self.kta_scale1_code as u16) << 4
            | self.kta_scale2 as u16;
        w[57] = ux(self.cp_alpha0 as i64, 10) | ux(self.cp_alpha_ratio as i64, 6) << 10;
        w[58] = ux(self.cp_offset0 as i64, 10) | ux(self.cp_offset_delta as i64, 6) << 10;
        w[59] = (self.cp_kv as u8 as u16) << 8 | self.cp_kta as u8 as u16;
        w[60] = (self.ks_ta as u8 as u16) << 8 | self.tgc as u8 as u16;
        w[61] = (self.ks_to[1] as u8 as u16) << 8 | self.ks_to[0] as u8 as u16;
        w[62] = (self.ks_to[3] as u8 as u16) << 8 | self.ks_to[2] as u8 as u16;
        w[63] |= (self.ct_step as u16) << 12
            | (self.ct4 as u16) << 8
            | (self.ct3 as u16) << 4
            | self.ks_to_scale as u16;
        for p in 0..PIXELS {
            w[64 + p] = self.pixel_word(p);
        }
        Ok(w)
    }
}

/// The datasheet worked example's words 0x2430–0x243F (Rev. 12 §11, table 12; the same words
/// as `shared/data/mlx90640/datasheet_example_eeprom.hex`), decoded:
///
/// | word | value | fields |
/// |---|---|---|
/// | 0x2430 | 0x18EF | GAIN 6383 |
/// | 0x2431 | 0x2FF1 | V_PTAT25 12273 |
/// | 0x2432 | 0x5952 | K_V_PTAT 22/4096 = 0.00537 /V, K_T_PTAT 338/8 = 42.25 |
/// | 0x2433 | 0x9D68 | K_Vdd −99·32 = −3168, VDD_25 (104 − 256)·32 − 8192 = −13056 |
/// | 0x2434 | 0x5454 | Kv by parity 5, 5, 4, 4 (/2³ = 0.625, 0.625, 0.5, 0.5 /V) |
/// | 0x2435 | 0x0994 | IL_CHESS_C1 20/16 = 1.25, C2 6/2 = 3, C3 1/8 = 0.125 |
/// | 0x2436–7 | 0x6956 0x5354 | KtaRC 105, 83, 86, 84 (/2¹⁴ ≈ 0.0064, 0.0051, 0.0052, 0.0051 /°C) |
/// | 0x2438 | 0x2363 | resolution 18 bit (code 2), Kv scale 3, Kta scales 14 and 3 |
/// | 0x2439 | 0xE446 | CP alpha 70/2³⁴ = 4.07·10⁻⁹ and (1 − 7/128)× that = 3.85·10⁻⁹ |
/// | 0x243A | 0xFBB5 | CP offsets −75 and −77 LSB |
/// | 0x243B | 0x044B | K_Ta_CP 75/2¹⁴ = 0.00458 /°C, K_V_CP 4/2³ = 0.5 /V |
/// | 0x243C | 0xF020 | TGC 32/32 = 1, KsTa −16/8192 = −0.00195 /°C |
/// | 0x243D–E | 0x9797 0x9797 | KsTo −105/2¹⁷ = −0.00080 /°C for ranges 1–4 |
/// | 0x243F | 0x2889 | CT step 20 °C, CT3 = 160 °C, CT4 = 320 °C, KsTo scale 2¹⁷ |
pub const DATASHEET_WORDS_48_63: [u16; 16] = [
    0x18EF, 0x2FF1, 0x5952, 0x9D68, 0x5454, 0x0994, 0x6956, 0x5354, 0x2363, 0xE446, 0xFBB5, 0x044B,
    0xF020, 0x9797, 0x9797, 0x2889,
];

/// The datasheet example's words 0x2410 (Alpha_PTAT code 4, i.e. Alpha_PTAT = 9; offset
/// row/column/remnant scales 2, 1, 0) and 0x2411 (offset reference −69 LSB).
pub const DATASHEET_WORDS_16_17: [u16; 2] = [0x4210, 0xFFBB];

/// Offset reference of [`realistic`], LSB: the middle of the −111…−47 LSB spans of the real
/// dumps in `shared/data/mlx90640` (the datasheet example's reference is −69).
pub const REALISTIC_OFFSET_REF: i16 = -85;

/// Alpha reference of [`realistic`] at scale 2⁻³⁷: 16 400/2³⁷ = 1.193·10⁻⁷, the middle of the
/// 1.0–1.3·10⁻⁷ band (the datasheet example's pixel (12, 16) has 1.26·10⁻⁷).
pub const REALISTIC_ALPHA_REF: u16 = 16_400;

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, seedable, well-mixed 64-bit generator.
struct SplitMix64(u64);

impl SplitMix64 {
    /// Return the next 64 random bits.
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Return an integer uniform in `lo..=hi` (the modulo bias is below 10⁻¹⁷ here).
    fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as i64
    }
}

/// Row or column correction of a parabolic vignetting: +4 at the centre of `n` cells, −4 at
/// both edges (`4 − 8·x²` with `x` in −1…1, rounded).
fn vignette(i: usize, n: usize) -> i8 {
    let half = (n as f64 - 1.0) / 2.0;
    let x = (i as f64 - half) / half;
    (4.0 - 8.0 * x * x).round() as i8
}

/// Return the EEPROM fields of a realistic MLX90640BAB (55° field of view) with a seeded
/// per-pixel spread: the same seed gives the same fields, different seeds different spreads.
///
/// - Global words 0x2430–0x243F: the datasheet's worked example, [`DATASHEET_WORDS_48_63`]
///   (GAIN 6383, V_PTAT25 12273, K_V_PTAT 0.00537 /V, K_T_PTAT 42.25, K_Vdd −3168,
///   VDD_25 −13056, CP, TGC 1, KsTa −0.00195 /°C, KsTo −0.0008 /°C, CT 160/320 °C,
///   calibrated at 18 bit), except the Kv and Kta parity tables, each entry moved by a seeded
///   ±1 (Kv, of 4–5) and ±3 (KtaRC, of 83–105): parts differ there by that much in the real
///   dumps. TGC stays the datasheet's 1 (the real dumps have 0) so the TGC path is exercised;
///   it lowers every alpha by TGC·(mean CP alpha) = 0.04·10⁻⁷.
/// - Alpha_PTAT 9 and the offset scales (row ×4, column ×2, remnant ×1):
///   [`DATASHEET_WORDS_16_17`]; calibrated in chess mode, as real parts.
/// - Offsets: reference [`REALISTIC_OFFSET_REF`] (−85 LSB), row and column corrections uniform
///   in ±4 (±16 and ±8 LSB) and a per-pixel remnant uniform in ±10 LSB, so every pixel offset
///   lies in −119…−51 LSB (real dumps: rows −7…3, columns −7…5, remnants −12…9).
/// - Sensitivity: scale 2⁻³⁷ (datasheet's), reference [`REALISTIC_ALPHA_REF`], row and column
///   corrections of a parabolic vignetting (+4 at the centre, −4 at the edges, × 2⁸) — alpha
///   ±12.5 % from centre to corner, the most that keeps the band 1.0–1.3·10⁻⁷ with the pixel
///   noise (real BAB parts vignette more, up to −40 % at the corners) — and a per-pixel
///   remnant uniform in ±12 (× 2⁴, ±1.2 %). Every alpha lies in 0.99–1.32·10⁻⁷ (after the
///   TGC term), so at 263 K a pixel gives 4·alpha·T³ ≥ 7 counts/K (one count ≤ 0.14 K).
/// - Kta remnant uniform in ±2 (× 2³); Kv has no per-pixel field.
/// - No broken or outlier pixels (a pixel whose word would be 0 gets alpha remnant 1).
pub fn realistic(seed: u64) -> EepromFields {
    let mut words = [0u16; EEPROM_WORDS];
    words[16..18].copy_from_slice(&DATASHEET_WORDS_16_17);
    words[48..64].copy_from_slice(&DATASHEET_WORDS_48_63);
    let mut f = EepromFields::decode(&words);
    let mut rng = SplitMix64(seed ^ 0x0EE9_803A_0000);
    f.interleaved_calibration = false;
    f.offset_ref = REALISTIC_OFFSET_REF;
    for v in f.occ_row.iter_mut().chain(f.occ_column.iter_mut()) {
        *v = rng.range(-4, 4) as i8;
    }
    f.alpha_scale_code = 7;
    f.acc_row_scale = 8;
    f.acc_column_scale = 8;
    f.acc_rem_scale = 4;
    f.alpha_ref = REALISTIC_ALPHA_REF;
    f.acc_row = std::array::from_fn(|i| vignette(i, ROWS));
    f.acc_column = std::array::from_fn(|j| vignette(j, COLS));
    for v in f.kv_t.iter_mut() {
        *v += rng.range(-1, 1) as i8;
    }
    for v in f.kta_rc.iter_mut() {
        *v += rng.range(-3, 3) as i8;
    }
    for p in 0..PIXELS {
        f.broken[p] = false;
        f.outlier[p] = false;
        f.offset_delta[p] = rng.range(-10, 10) as i8;
        f.alpha_delta[p] = rng.range(-12, 12) as i8;
        f.kta_delta[p] = rng.range(-2, 2) as i8;
        if f.pixel_word(p) == 0 {
            f.alpha_delta[p] = 1;
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use thermorph::mlx90640::{Calibration, CalibrationError};

    fn random_words(seed: u64) -> [u16; EEPROM_WORDS] {
        let mut rng = SplitMix64(seed);
        std::array::from_fn(|_| rng.next_u64() as u16)
    }

    #[test]
    fn words_fields_words_is_identity() {
        for seed in 0..200 {
            let mut w = random_words(seed);
            // Some broken pixels and all-zero or all-one words too.
            w[64 + seed as usize % PIXELS] = 0;
            if seed % 7 == 0 {
                w[..64].fill(if seed % 2 == 0 { 0 } else { 0xFFFF });
            }
            let f = EepromFields::decode(&w);
            assert_eq!(f.encode().unwrap(), w, "seed {seed}");
        }
        for fill in [0, 0xFFFF] {
            let w = [fill; EEPROM_WORDS];
            assert_eq!(EepromFields::decode(&w).encode().unwrap(), w, "{fill:04X}");
        }
        let Some(dir) =
            crate::imaging::data::require_mlx90640_dir("words_fields_words_is_identity")
        else {
            return;
        };
        let mut dumps: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| {
                let name = p.file_name().unwrap().to_string_lossy();
                name.contains("eeprom") && name.ends_with(".hex")
            })
            .collect();
        dumps.sort();
        assert!(dumps.len() >= 6, "EEPROM dumps in {}", dir.display());
        for path in dumps {
            let w = crate::imaging::dump::read_eeprom(&path).unwrap();
            let f = EepromFields::decode(&w);
            assert_eq!(f.encode().unwrap(), w, "{}", path.display());
            assert_eq!(EepromFields::decode(&f.encode().unwrap()), f);
        }
    }

    #[test]
    fn fields_words_fields_is_identity() {
        for seed in 0..10 {
            let f = realistic(seed);
            assert_eq!(EepromFields::decode(&f.encode().unwrap()), f, "seed {seed}");
        }
        // Fields at the ends of their ranges.
        let mut f = realistic(3);
        f.occ_row[0] = -8;
        f.occ_column[31] = 7;
        f.kv_ptat = -32;
        f.kt_ptat = 511;
        f.il_chess_c1 = 31;
        f.il_chess_c2 = -16;
        f.il_chess_c3 = 15;
        f.cp_alpha0 = -512;
        f.cp_offset_delta = 31;
        f.resolution = 3;
        f.ct_step = 3;
        f.offset_delta[0] = -32;
        f.alpha_delta[1] = 31;
        f.kta_delta[2] = -4;
        f.outlier[3] = true;
        f.mark_broken(700);
        f.interleaved_calibration = true;
        f.reserved[0] = 0xBEEF;
        f.reserved[10] = 0xF7FF;
        f.reserved[56] = 0xC000;
        assert_eq!(EepromFields::decode(&f.encode().unwrap()), f);
        // Random in-range fields (every decoded word set is in range).
        for seed in 100..120 {
            let f = EepromFields::decode(&random_words(seed));
            assert_eq!(EepromFields::decode(&f.encode().unwrap()), f, "seed {seed}");
        }
    }

    #[test]
    fn fields_out_of_range_are_refused_by_name() {
        type Spoil = fn(&mut EepromFields);
        let cases: [(&str, Spoil); 12] = [
            ("alpha_delta[5]", |f| f.alpha_delta[5] = 32),
            ("offset_delta[6]", |f| f.offset_delta[6] = -33),
            ("kta_delta[7]", |f| f.kta_delta[7] = 4),
            ("kt_ptat", |f| f.kt_ptat = 600),
            ("kv_ptat", |f| f.kv_ptat = 32),
            ("occ_row[3]", |f| f.occ_row[3] = 8),
            ("acc_column[9]", |f| f.acc_column[9] = -9),
            ("kv_t[2]", |f| f.kv_t[2] = 8),
            ("resolution", |f| f.resolution = 4),
            ("il_chess_c2", |f| f.il_chess_c2 = 16),
            ("reserved[20]", |f| f.reserved[20] = 1),
            ("broken[3]", |f| f.broken[3] = true),
        ];
        for (name, spoil) in cases {
            let mut f = realistic(1);
            spoil(&mut f);
            let err = f.encode().unwrap_err();
            assert!(err.to_string().contains(name), "{name}: {err}");
            assert_eq!(f.validate().unwrap_err(), err);
        }
        // A pixel that is not broken but whose word would be 0.
        let mut f = realistic(1);
        f.offset_delta[4] = 0;
        f.alpha_delta[4] = 0;
        f.kta_delta[4] = 0;
        assert!(f.encode().unwrap_err().to_string().contains("broken[4]"));
    }

    #[test]
    fn seeds_are_deterministic_and_distinct() {
        assert_eq!(realistic(4), realistic(4));
        let (a, b) = (realistic(4), realistic(5));
        assert_ne!(a.offset_delta, b.offset_delta);
        assert_ne!(a.alpha_delta, b.alpha_delta);
        assert_ne!(a.kta_delta, b.kta_delta);
        assert_ne!(a.occ_row, b.occ_row);
    }

    #[test]
    fn realistic_keeps_the_datasheet_globals() {
        let f = realistic(8);
        let w = f.encode().unwrap();
        for k in [48, 49, 50, 51, 53, 56, 57, 58, 59, 60, 61, 62, 63] {
            assert_eq!(w[k], DATASHEET_WORDS_48_63[k - 48], "word {k}");
        }
        assert_eq!(w[16], DATASHEET_WORDS_16_17[0]);
        let cal = Calibration::from_eeprom(&w).unwrap();
        assert_eq!((cal.k_vdd, cal.vdd25, cal.gain_ee), (-3168, -13056, 6383));
        assert_eq!((cal.v_ptat25, cal.alpha_ptat), (12273, 9.0));
        assert_eq!((cal.kv_ptat, cal.kt_ptat), (22.0 / 4096.0, 42.25));
        assert_eq!((cal.resolution_ee, cal.calibration_mode_ee), (2, 0x80));
        assert_eq!((cal.tgc, cal.ks_ta), (1.0, -16.0 / 8192.0));
        assert_eq!(cal.ks_to[0], -105.0 / 131_072.0);
        assert_eq!(cal.ct, [-40, 0, 160, 320, 400]);
        assert!(cal.broken_pixels.as_slice().is_empty());
        assert!(cal.outlier_pixels.as_slice().is_empty());
    }

    /// A pixel's calibration parameters in `f64`.
    struct PixelParams {
        alpha: f64,
        offset: i32,
        kta: f64,
        kv: f64,
    }

    /// The library's per-pixel formulas (datasheet §11.1.6–11.1.9), evaluated exactly in
    /// `f64` straight from the fields, without the library's requantisation.
    fn expected_pixel_params(f: &EepromFields, p: usize) -> PixelParams {
        let (i, j) = (p / COLS, p % COLS);
        let pow2 = |e: i32| 2f64.powi(e);
        let offset = f.offset_ref as i32
            + f.occ_row[i] as i32 * (1 << f.occ_row_scale)
            + f.occ_column[j] as i32 * (1 << f.occ_column_scale)
            + f.offset_delta[p] as i32 * (1 << f.occ_rem_scale);
        let cp0 = f.cp_alpha0 as f64 / pow2(f.alpha_scale_code as i32 + 27);
        let cp1 = (1.0 + f.cp_alpha_ratio as f64 / 128.0) * cp0;
        let alpha = (f.alpha_ref as f64
            + f.acc_row[i] as f64 * pow2(f.acc_row_scale as i32)
            + f.acc_column[j] as f64 * pow2(f.acc_column_scale as i32)
            + f.alpha_delta[p] as f64 * pow2(f.acc_rem_scale as i32))
            / pow2(f.alpha_scale_code as i32 + 30)
            - f.tgc as f64 / 32.0 * (cp0 + cp1) / 2.0;
        let parity = 2 * (i % 2) + j % 2;
        let kta = (f.kta_rc[parity] as f64 + f.kta_delta[p] as f64 * pow2(f.kta_scale2 as i32))
            / pow2(f.kta_scale1_code as i32 + 8);
        let kv = f.kv_t[parity] as f64 / pow2(f.kv_scale as i32);
        PixelParams {
            alpha,
            offset,
            kta,
            kv,
        }
    }

    #[test]
    fn extraction_gives_the_designed_pixels() {
        for seed in [1, 2, 3, 4, 5] {
            let f = realistic(seed);
            let cal = Calibration::from_eeprom(&f.encode().unwrap()).unwrap();
            let (mut lo, mut hi) = (f64::MAX, 0f64);
            let (mut centre, mut corner) = (0f64, 0f64);
            for p in 0..PIXELS {
                let want = expected_pixel_params(&f, p);
                assert_eq!(cal.offset[p] as i32, want.offset, "seed {seed} offset[{p}]");
                assert!(
                    (-120..=-50).contains(&want.offset),
                    "seed {seed} offset[{p}] = {}",
                    want.offset
                );
                // The library keeps 1e-6/alpha as a rounded 16-bit integer.
                let got = cal.alpha_of(p) as f64;
                let tol = 0.5 / cal.alpha[p] as f64 + 1e-6;
                assert!(
                    ((got - want.alpha) / want.alpha).abs() <= tol,
                    "seed {seed} alpha[{p}] {got:e} vs {:e}",
                    want.alpha
                );
                // Kta and Kv are requantised to 8 bits with the library's scale.
                let kta_step = 1.0 / 2f64.powi(cal.kta_scale as i32);
                assert!(
                    (cal.kta_of(p) as f64 - want.kta).abs() <= kta_step / 2.0 + 1e-12,
                    "seed {seed} kta[{p}]"
                );
                assert_eq!(cal.kv_of(p) as f64, want.kv, "seed {seed} kv[{p}]");
                lo = lo.min(want.alpha);
                hi = hi.max(want.alpha);
                let (i, j) = (p / COLS, p % COLS);
                if (11..13).contains(&i) && (15..17).contains(&j) {
                    centre += want.alpha / 4.0;
                }
                if (i == 0 || i == ROWS - 1) && (j == 0 || j == COLS - 1) {
                    corner += want.alpha / 4.0;
                }
            }
            assert!(lo > 0.98e-7 && hi < 1.32e-7, "alpha range {lo:e}..{hi:e}");
            // One 18-bit count at 263 K is below 0.15 K: at least 6 counts/K.
            assert!(4.0 * lo * 263f64.powi(3) >= 6.0);
            // Vignetting: the centre is about 25 % more sensitive than the corners.
            let ratio = centre / corner;
            assert!((1.2..1.35).contains(&ratio), "centre/corner alpha {ratio}");
        }
    }

    #[test]
    fn bad_pixels_are_refused_as_the_library_does() {
        let refuse = |f: &EepromFields| Calibration::from_eeprom(&f.encode().unwrap()).unwrap_err();
        let spread = [10, 100, 200, 300, 400];

        let mut f = realistic(9);
        for &p in &spread[..4] {
            f.mark_broken(p);
        }
        let cal = Calibration::from_eeprom(&f.encode().unwrap()).unwrap();
        assert_eq!(cal.broken_pixels.as_slice(), &[10, 100, 200, 300]);
        f.mark_broken(spread[4]);
        assert_eq!(refuse(&f), CalibrationError::TooManyBrokenPixels);

        let mut f = realistic(9);
        for &p in &spread[..4] {
            f.outlier[p] = true;
        }
        let cal = Calibration::from_eeprom(&f.encode().unwrap()).unwrap();
        assert_eq!(cal.outlier_pixels.as_slice(), &[10, 100, 200, 300]);
        f.outlier[spread[4]] = true;
        assert_eq!(refuse(&f), CalibrationError::TooManyOutlierPixels);

        let mut f = realistic(9);
        for &p in &spread[..3] {
            f.mark_broken(p);
        }
        f.outlier[spread[3]] = true;
        f.outlier[spread[4]] = true;
        assert_eq!(refuse(&f), CalibrationError::TooManyBadPixels);

        let mut f = realistic(9);
        f.mark_broken(100);
        f.mark_broken(101);
        assert_eq!(
            refuse(&f),
            CalibrationError::AdjacentBadPixels {
                first: 100,
                second: 101
            }
        );
        let mut f = realistic(9);
        f.mark_broken(100);
        f.outlier[133] = true;
        assert_eq!(
            refuse(&f),
            CalibrationError::AdjacentBadPixels {
                first: 100,
                second: 133
            }
        );
    }
}
