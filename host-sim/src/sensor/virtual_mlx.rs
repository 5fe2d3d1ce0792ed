//! A virtual MLX90640 on a simulated I2C bus, for the real driver to read.
//!
//! The device holds an EEPROM (any 832 words: a real dump or one written by
//! [`crate::sensor::eeprom`]), serves the status and control registers, and measures a subpage every
//! refresh period of simulated time, alternating subpages. A measurement encodes the true
//! temperature field (K per pixel, plus sensor noise), the sensor temperature Ta and the supply
//! Vdd into raw RAM words by inverting the calibration the EEPROM describes — the exact
//! inverse of the Melexis calculation in `thermorph::mlx90640::calc`, solved in `f64` and
//! rounded to the ADC's integer counts — so the firmware's own driver decodes it.
//!
//! What limits the round trip is that rounding: one ADC count is worth 1/(4·α·T³·gain⁻¹)
//! kelvin, about 0.05–0.15 K at 18 bit for a BAB-class sensor (α ≈ 1.1e-7) between 263 and
//! 573 K, twice that per resolution bit less, half per bit more. Ta and Vdd round too (PTAT and
//! Vbe are chosen together to put Ta within a few mK).
//!
//! Injectable faults ([`SensorFault`]): NACK, bus timeout (a transfer that never completes), a bus
//! held low (every transfer hangs until a bus recovery, [`VirtualBus`]'s
//! [`RecoverBus`] implementation, clocks it free), stuck (no new data), 0x7FFF corruption, and
//! a frozen frame (RAM stops changing while the new-data flag keeps coming). A power cycle
//! ([`VirtualMlx90640::power_cycle`]) puts the control register back to its 2 Hz default.
//!
//! Bus time: every transfer advances the simulated clock by its duration at 400 kHz
//! (9 bit times per byte), so reading a subpage costs ≈ 40 ms as on the board.
//!
//! Speed (`host-sim run` encodes every 8 Hz subpage): the encoder's per-pixel constants are
//! kept while the control register, Ta and Vdd stay; each pixel's signal comes from a table of
//! the inverse (cubic pieces 1 K wide, built as needed), checked to round as the secant
//! method's would (else solved by it: a few words in 10⁴); the noise is drawn ahead on a
//! thread of its own, in the generator's order; the words are worked out from the table's
//! signals two pixels at a time (SSE2 on x86-64). The words are the same as solving every pixel
//! by the secant method ([`VirtualMlx90640::encode_subpage_exact`]).

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::mpsc::Receiver;

use embedded_hal::i2c::{ErrorKind, ErrorType, NoAcknowledgeSource, Operation};
use embedded_hal_async::i2c::I2c;
use thermorph::mlx90640::calc::{
    IDX_CP_SP0, IDX_CP_SP1, IDX_GAIN, IDX_PTAT, IDX_VBE, IDX_VDD, conversion_pattern, il_pattern,
    pixel_in_subpage,
};
use thermorph::mlx90640::{
    AUX_WORDS, Calibration, CalibrationError, Control, EEPROM_START, EEPROM_WORDS, PIXELS,
    RAM_START, Status, SubpageFrame,
};

use thermorph::mlx90640::Image;
use thermorph::sensing::{Buffers, BusStuck, Clock, Parts, RecoverBus, Storage};
use thermorph::units::Millis;

use crate::sensor::sim_time::SimClock;

/// Bit time on the simulated bus, ns (400 kHz).
pub const BIT_TIME_NS: u64 = 2_500;

/// A fault the virtual device can be told to show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorFault {
    /// Every transfer is refused with a NACK of the address.
    Nack,
    /// Every transfer hangs forever (the driver's timeout must fire).
    BusTimeout,
    /// The sensor holds SDA low (a transfer abandoned midway): every transfer hangs until a
    /// bus recovery (nine SCL clocks and a STOP) releases it, which clears this fault.
    BusStuckLow,
    /// Measurement stops: the new-data flag never comes.
    Stuck,
    /// Measurements write 0x7FFF into an aux word and a checked pixel word.
    Corrupt,
    /// RAM stops changing but the new-data flag keeps coming.
    Frozen,
}

/// A small deterministic PRNG (SplitMix64) with Gaussian samples.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// Make a generator from a seed.
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// Return the next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Return a uniform sample in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Return a standard normal sample (Box–Muller).
    pub fn gauss(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// The sensor's noise: the standard normal samples of its [`Rng`], in the generator's order,
/// drawn ahead in blocks on a thread of their own once the sensor first needs one (the other
/// core is idle while the simulation runs) — the same numbers in the same order as drawing
/// them one at a time.
struct Noise {
    /// The generator, until the thread takes it.
    rng: Option<Rng>,
    blocks: Option<Receiver<Vec<f64>>>,
    block: Vec<f64>,
    used: usize,
}

impl Noise {
    /// Samples per block: sixteen subpages'.
    const BLOCK: usize = 16 * PIXELS / 2;
    /// Blocks drawn ahead.
    const AHEAD: usize = 2;

    fn new(rng: Rng) -> Self {
        Noise {
            rng: Some(rng),
            blocks: None,
            block: Vec::new(),
            used: 0,
        }
    }

    /// The next sample.
    #[inline]
    fn next(&mut self) -> f64 {
        if self.used == self.block.len() {
            self.refill();
        }
        self.used += 1;
        self.block[self.used - 1]
    }

    fn refill(&mut self) {
        if self.blocks.is_none() {
            let mut rng = self
                .rng
                .take()
                .expect("the generator until the thread starts");
            let (tx, rx) = std::sync::mpsc::sync_channel(Self::AHEAD);
            let drawn = std::thread::Builder::new()
                .name("sensor-noise".into())
                .spawn(move || {
                    loop {
                        let block: Vec<f64> = (0..Self::BLOCK).map(|_| rng.gauss()).collect();
                        // The sensor is gone: stop.
                        if tx.send(block).is_err() {
                            break;
                        }
                    }
                });
            drawn.expect("cannot start the sensor noise thread");
            self.blocks = Some(rx);
        }
        let rx = self.blocks.as_ref().expect("started above");
        self.block = rx.recv().expect("the noise thread never stops first");
        self.used = 0;
    }
}

/// The virtual sensor's state (shared behind [`VirtualBus`]).
pub struct VirtualMlx90640 {
    eeprom: [u16; EEPROM_WORDS],
    cal: Calibration,
    ram: [u16; PIXELS + AUX_WORDS],
    control: u16,
    status: u16,
    clock: SimClock,
    next_measurement_us: u64,
    next_subpage: u8,
    /// True object temperature per pixel, K (row-major 24 × 32).
    pub field_k: [f32; PIXELS],
    /// Sensor (ambient) temperature, K.
    pub ta_k: f64,
    /// Supply voltage, V.
    pub vdd_v: f64,
    /// Noise added to each pixel's temperature per measurement, K rms (NETD).
    pub noise_k: f64,
    fault: Option<SensorFault>,
    noise: Noise,
    measurements: u64,
    recoveries: u64,
    /// The encoders of the two subpages, kept while their key holds.
    encoders: [Option<Box<Encoder>>; 2],
    table: InverseTable,
    exact_pixels: u64,
}

/// Default sensor temperature, K (a camera a few kelvin above a 298 K room).
pub const DEFAULT_TA_K: f64 = 303.15;
/// Default supply, V.
pub const DEFAULT_VDD_V: f64 = 3.3;
/// Default noise, K rms: the datasheet's NETD of about 0.1 K at 4 Hz frames.
pub const DEFAULT_NOISE_K: f64 = 0.1;
/// The device's power-on control register: chess, 18 bit, 2 Hz (datasheet §8.2.2.2).
pub const POWER_ON_CONTROL: u16 = 0x1901;

impl VirtualMlx90640 {
    /// Make a device from EEPROM words; fails if the calibration is refused (as the driver
    /// would), since the device inverts that calibration.
    pub fn new(
        eeprom: [u16; EEPROM_WORDS],
        clock: SimClock,
        seed: u64,
    ) -> Result<Self, CalibrationError> {
        let cal = Calibration::from_eeprom(&eeprom)?;
        let period = Control(POWER_ON_CONTROL).refresh_rate().period_us() as u64;
        Ok(VirtualMlx90640 {
            eeprom,
            cal,
            ram: [0; PIXELS + AUX_WORDS],
            control: POWER_ON_CONTROL,
            status: 0,
            next_measurement_us: clock.now_us() + period,
            clock,
            next_subpage: 0,
            field_k: [DEFAULT_TA_K as f32; PIXELS],
            ta_k: DEFAULT_TA_K,
            vdd_v: DEFAULT_VDD_V,
            noise_k: DEFAULT_NOISE_K,
            fault: None,
            noise: Noise::new(Rng::new(seed)),
            measurements: 0,
            recoveries: 0,
            encoders: [None, None],
            table: InverseTable::new(),
            exact_pixels: 0,
        })
    }

    /// Return the calibration the device inverts.
    pub fn calibration(&self) -> &Calibration {
        &self.cal
    }

    /// When the next subpage will be measured (from the field as it is then), µs: updated as
    /// the bus is used, so it may lie in the past.
    pub fn next_measurement_us(&self) -> u64 {
        self.next_measurement_us
    }

    /// Show `fault` from now on (`None` heals the device).
    pub fn set_fault(&mut self, fault: Option<SensorFault>) {
        self.fault = fault;
    }

    /// Return the active fault.
    pub fn fault(&self) -> Option<SensorFault> {
        self.fault
    }

    /// Return how many bus recoveries were run.
    pub fn recoveries(&self) -> u64 {
        self.recoveries
    }

    /// Turn the device off and on: the control register back to its power-on value (2 Hz),
    /// no new data, measurement restarting with subpage 0 one period later.
    pub fn power_cycle(&mut self) {
        self.control = POWER_ON_CONTROL;
        self.status = 0;
        self.next_subpage = 0;
        let period = self.control().refresh_rate().period_us() as u64;
        self.next_measurement_us = self.clock.now_us() + period;
    }

    /// A bus recovery as the board runs it: up to nine SCL clocks and a STOP at 100 kHz
    /// (≈ 100 µs); releases a bus held low.
    fn recover_bus(&mut self) {
        self.recoveries += 1;
        self.clock.advance_us(100);
        if self.fault == Some(SensorFault::BusStuckLow) {
            self.fault = None;
        }
    }

    /// Return how many subpages have been measured.
    pub fn measurements(&self) -> u64 {
        self.measurements
    }

    /// Return the control register.
    pub fn control(&self) -> Control {
        Control(self.control)
    }

    /// Run the measurements due by the clock's time (only the last two if many are due).
    pub fn advance(&mut self) {
        let now = self.clock.now_us();
        let period = self.control().refresh_rate().period_us() as u64;
        if self.next_measurement_us > now {
            return;
        }
        let due = (now - self.next_measurement_us) / period + 1;
        if due > 2 {
            // Skip whole pairs: only the last two measurements can still be seen.
            let skip = (due - 2) & !1;
            self.next_measurement_us += skip * period;
        }
        while self.next_measurement_us <= now {
            self.measure();
            self.next_measurement_us += period;
        }
    }

    fn measure(&mut self) {
        if self.fault == Some(SensorFault::Stuck) {
            return;
        }
        let sp = self.next_subpage;
        self.next_subpage ^= 1;
        self.measurements += 1;
        if self.fault != Some(SensorFault::Frozen) {
            self.encode_subpage(sp);
        }
        if self.fault == Some(SensorFault::Corrupt) {
            self.ram[PIXELS] = 0x7FFF; // aux word 0 (Vbe)
            self.ram[(2 + sp as usize) * 32] = 0x7FFF; // first pixel of a row of this parity
        }
        self.status = (self.status & !(Status::SUBPAGE | 0x6)) | Status::NEW_DATA | sp as u16;
    }

    /// Encode the current field, Ta and Vdd into subpage `sp`'s RAM words.
    ///
    /// The words are those of [`Self::encode_subpage_exact`], found faster: the encoder's
    /// per-pixel constants kept while the control register, Ta and Vdd stay, the signal from a
    /// table of the inverse, and the secant method only where the table's word could round
    /// differently (see `Encoder::word_of_unit`).
    pub fn encode_subpage(&mut self, sp: u8) {
        let key = EncoderKey {
            control: self.control,
            sp,
            ta_bits: self.ta_k.to_bits(),
            vdd_bits: self.vdd_v.to_bits(),
        };
        let slot = &mut self.encoders[sp as usize & 1];
        if slot.as_ref().is_none_or(|e| e.key != key) {
            *slot = Some(Box::new(Encoder::new(&self.cal, key)));
        }
        let enc = slot.as_deref().expect("built above");
        self.table.prepare(enc);
        enc.write_aux(&mut self.ram);
        let noise = self.noise_k > 0.0;
        // Each pixel's temperature (the noise drawn in pixel order) and the table's signal for
        // a unit alpha (NaN where the table has none), then the words two pixels at a time.
        let n = enc.pixels.len();
        let mut to_k = [0f64; PIXELS];
        let mut unit = [0f64; PIXELS];
        for ((&p, t), u) in enc.pixels.iter().zip(&mut to_k).zip(&mut unit) {
            let mut v = self.field_k[p as usize] as f64;
            if noise {
                v += self.noise_k * self.noise.next();
            }
            *t = v;
            *u = self.table.unit_ir(enc, v).unwrap_or(f64::NAN);
        }
        let mut words = [None; PIXELS];
        enc.words_of_units(&unit[..n], &mut words[..n]);
        for ((&p, &t), w) in enc.pixels.iter().zip(&to_k).zip(&words) {
            let p = p as usize;
            self.ram[p] = match *w {
                Some(w) => w,
                None => {
                    self.exact_pixels += 1;
                    enc.pixel_raw(p, t)
                }
            } as u16;
        }
    }

    /// Return how many pixel words [`Self::encode_subpage`] had to find by the secant method.
    pub fn exact_pixels(&self) -> u64 {
        self.exact_pixels
    }

    /// [`Self::encode_subpage`] without the table: every pixel by the secant method (the
    /// reference the fast path must match word for word).
    pub fn encode_subpage_exact(&mut self, sp: u8) {
        let key = EncoderKey {
            control: self.control,
            sp,
            ta_bits: self.ta_k.to_bits(),
            vdd_bits: self.vdd_v.to_bits(),
        };
        let enc = Encoder::new(&self.cal, key);
        enc.write_aux(&mut self.ram);
        let pattern = Control(self.control).pattern();
        for p in 0..PIXELS {
            if !pixel_in_subpage(p, pattern, sp) {
                continue;
            }
            let mut t = self.field_k[p] as f64;
            if self.noise_k > 0.0 {
                t += self.noise_k * self.noise.next();
            }
            self.ram[p] = enc.pixel_raw(p, t) as u16;
        }
    }

    /// Encode subpage `sp` of the current field and return it as the driver would read it
    /// (RAM, control register, subpage number) — for benches and tests that skip the bus.
    pub fn raw_subpage(&mut self, sp: u8) -> SubpageFrame {
        self.encode_subpage(sp);
        let mut f = SubpageFrame::new();
        f.words[..PIXELS + AUX_WORDS].copy_from_slice(&self.ram);
        f.words[PIXELS + AUX_WORDS] = self.control;
        f.words[PIXELS + AUX_WORDS + 1] = sp as u16;
        f
    }

    /// Set the control register directly (as a write over the bus would).
    pub fn set_control(&mut self, control: Control) {
        self.control = control.0;
    }

    fn read_word(&self, addr: u16) -> u16 {
        let a = addr as usize;
        let ee = EEPROM_START as usize;
        let ram = RAM_START as usize;
        if (ee..ee + EEPROM_WORDS).contains(&a) {
            self.eeprom[a - ee]
        } else if (ram..ram + PIXELS + AUX_WORDS).contains(&a) {
            self.ram[a - ram]
        } else if addr == Status::ADDRESS {
            self.status
        } else if addr == Control::ADDRESS {
            self.control
        } else {
            0
        }
    }

    fn write_word(&mut self, addr: u16, value: u16) -> Result<(), ErrorKind> {
        match addr {
            Status::ADDRESS => {
                // Bits 0–2 (subpage) are read-only; writing 0 to bit 3 clears new data.
                self.status = (self.status & 0x0007)
                    | (value & !0x0007 & !Status::NEW_DATA)
                    | (self.status & value & Status::NEW_DATA);
                Ok(())
            }
            Control::ADDRESS => {
                let old_period = self.control().refresh_rate().period_us() as u64;
                self.control = value;
                let period = self.control().refresh_rate().period_us() as u64;
                if period != old_period {
                    self.next_measurement_us = self.clock.now_us() + period;
                }
                Ok(())
            }
            // EEPROM writes need the erase/write protocol; the driver never writes it.
            _ => Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data)),
        }
    }

    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        let bytes: usize = ops
            .iter()
            .map(|op| match op {
                Operation::Read(b) => b.len(),
                Operation::Write(b) => b.len(),
            })
            .sum();
        self.clock
            .advance_us(((bytes as u64 + 1) * 9 * BIT_TIME_NS).div_ceil(1000));
        self.transact(address, ops)
    }

    /// One I2C transaction at the clock's present time (a bus that keeps its own time, as the
    /// emulated chip's I2C1 does, sets the clock; [`VirtualBus`] advances it by the bytes'
    /// time first): the measurements due run, then the operations.
    pub fn transact(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        self.advance();
        if self.fault == Some(SensorFault::Nack) || address != thermorph::mlx90640::ADDRESS {
            return Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address));
        }
        let mut pointer: Option<u16> = None;
        for op in ops.iter_mut() {
            match op {
                Operation::Write(b) => match b.len() {
                    2 => pointer = Some(u16::from_be_bytes([b[0], b[1]])),
                    4 => {
                        let reg = u16::from_be_bytes([b[0], b[1]]);
                        self.write_word(reg, u16::from_be_bytes([b[2], b[3]]))?;
                        pointer = None;
                    }
                    _ => return Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data)),
                },
                Operation::Read(buf) => {
                    let Some(start) = pointer else {
                        return Err(ErrorKind::Other);
                    };
                    if buf.len() % 2 != 0 {
                        return Err(ErrorKind::Other);
                    }
                    let n = buf.len() / 2;
                    let (a, ee, ram) = (start as usize, EEPROM_START as usize, RAM_START as usize);
                    // A block inside the EEPROM or the RAM (the driver's reads) in one go.
                    let block = if a >= ee && a + n <= ee + EEPROM_WORDS {
                        Some(&self.eeprom[a - ee..a - ee + n])
                    } else if a >= ram && a + n <= ram + PIXELS + AUX_WORDS {
                        Some(&self.ram[a - ram..a - ram + n])
                    } else {
                        None
                    };
                    match block {
                        Some(words) => {
                            for (pair, w) in buf.chunks_exact_mut(2).zip(words) {
                                pair.copy_from_slice(&w.to_be_bytes());
                            }
                        }
                        None => {
                            for (i, pair) in buf.chunks_exact_mut(2).enumerate() {
                                let w = self.read_word(start.wrapping_add(i as u16));
                                pair.copy_from_slice(&w.to_be_bytes());
                            }
                        }
                    }
                    pointer = Some(start.wrapping_add((buf.len() / 2) as u16));
                }
            }
        }
        Ok(())
    }
}

/// What an [`Encoder`] is built for: the control register, the subpage, Ta and Vdd. The
/// device keeps its encoders while these stay the same (they do for a whole run).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct EncoderKey {
    control: u16,
    sp: u8,
    ta_bits: u64,
    vdd_bits: u64,
}

/// The inverse of the Melexis calculation for one subpage: raw words from temperatures.
///
/// Everything that does not depend on the pixel's temperature is computed once per
/// [`EncoderKey`] (the aux words, each pixel's sensitivity, offset and IL/chess terms), with
/// the same operations as the per-pixel formula, so the words are the same bit for bit.
struct Encoder {
    key: EncoderKey,
    gain: f64,
    inv_gain: f64,
    gain_ram: i16,
    vdd_raw: i16,
    ptat_raw: i16,
    vbe_raw: i16,
    cp_raw: [i16; 2],
    ir_cp_tgc: f64,
    ta4: f64,
    /// KsTo of the four ranges.
    ks: [f64; 4],
    /// Corner temperatures CT1–CT4, °C.
    ct: [f64; 4],
    /// The ranges' alphaCorrR.
    corr: [f64; 4],
    /// `1 − KsTo₂·273.15`.
    one_minus: f64,
    /// Per pixel: alpha with the KsTa term (0 outside the subpage).
    alpha: Box<[f64; PIXELS]>,
    /// Per pixel: the IL/chess correction the decoder adds back (chess mode), else 0.
    il: Box<[f64; PIXELS]>,
    /// Per pixel: the offset with its Kta and Kv terms.
    offset: Box<[f64; PIXELS]>,
    calibration_mode: bool,
    /// The subpage's pixels, in order.
    pixels: Vec<u16>,
}

fn clamp_i16(x: f64) -> i16 {
    // 0x7FFF is the library's "not written" marker, so saturate one below it.
    x.round().clamp(-32768.0, 32766.0) as i16
}

impl Encoder {
    fn new(cal: &Calibration, key: EncoderKey) -> Self {
        let ctrl = Control(key.control);
        let (sp, ta_k, vdd_v) = (
            key.sp,
            f64::from_bits(key.ta_bits),
            f64::from_bits(key.vdd_bits),
        );
        let res_ram = ctrl.resolution() as i32;
        let res_shift = res_ram - cal.resolution_ee as i32;
        let gain_ram = clamp_i16(cal.gain_ee as f64 * 2f64.powi(res_shift));
        let gain = cal.gain_ee as f64 / gain_ram as f64;

        // Vdd: vdd = (corr·raw − vdd25)/kVdd + 3.3 with corr = 2^(resEE − resRAM).
        let corr = 2f64.powi(-res_shift);
        let vdd_raw = clamp_i16(((vdd_v - 3.3) * cal.k_vdd as f64 + cal.vdd25 as f64) / corr);
        let vdd = (corr * vdd_raw as f64 - cal.vdd25 as f64) / cal.k_vdd as f64 + 3.3;

        // Ta: ptatArt = ptat/(ptat·αPTAT + vbe)·2^18; choose ptat and vbe together.
        let ta_c_true = ta_k - 273.15;
        let art = ((ta_c_true - 25.0) * cal.kt_ptat as f64 + cal.v_ptat25 as f64)
            * (1.0 + cal.kv_ptat as f64 * (vdd - 3.3));
        let r = art / 262_144.0;
        let a = cal.alpha_ptat as f64;
        let ta_of = |ptat: f64, vbe: f64| {
            let art = ptat / (ptat * a + vbe) * 262_144.0;
            (art / (1.0 + cal.kv_ptat as f64 * (vdd - 3.3)) - cal.v_ptat25 as f64)
                / cal.kt_ptat as f64
                + 25.0
        };
        let mut best = (1711i16, 0i16, f64::INFINITY);
        for ptat in 1650..=1780 {
            let vbe = clamp_i16(ptat as f64 * (1.0 / r - a));
            let err = (ta_of(ptat as f64, vbe as f64) - ta_c_true).abs();
            if err < best.2 {
                best = (ptat as i16, vbe, err);
            }
        }
        let (ptat_raw, vbe_raw) = (best.0, best.1);
        let ta_c = ta_of(ptat_raw as f64, vbe_raw as f64);

        // Compensation pixels: they see the package, so their compensated signal is ≈ 0.
        let dta = ta_c - 25.0;
        let cp_factor = (1.0 + cal.cp_kta as f64 * dta) * (1.0 + cal.cp_kv as f64 * (vdd - 3.3));
        let calibration_mode = ctrl.mode_code() == cal.calibration_mode_ee;
        let cp_off = [
            cal.cp_offset[0] as f64,
            if calibration_mode {
                cal.cp_offset[1] as f64
            } else {
                cal.cp_offset[1] as f64 + cal.il_chess_c[0] as f64
            },
        ];
        let cp_raw = [
            clamp_i16(cp_off[0] * cp_factor / gain),
            clamp_i16(cp_off[1] * cp_factor / gain),
        ];
        let ir_cp = cp_raw[sp as usize] as f64 * gain - cp_off[sp as usize] * cp_factor;
        let ta4 = (ta_c + 273.15).powi(4);

        let ks: [f64; 4] = core::array::from_fn(|i| cal.ks_to[i] as f64);
        let ct: [f64; 4] = core::array::from_fn(|i| cal.ct[i] as f64);
        let r2 = 1.0 + ks[1] * ct[2];
        let corr = [
            1.0 / (1.0 + ks[0] * 40.0),
            1.0,
            r2,
            r2 * (1.0 + ks[2] * (ct[3] - ct[2])),
        ];
        let pattern = ctrl.pattern();
        let mut alpha = Box::new([0.0; PIXELS]);
        let mut il = Box::new([0.0; PIXELS]);
        let mut offset = Box::new([0.0; PIXELS]);
        let pixels: Vec<u16> = (0..PIXELS)
            .filter(|&p| pixel_in_subpage(p, pattern, sp))
            .map(|p| p as u16)
            .collect();
        for p in pixels.iter().map(|&p| p as usize) {
            alpha[p] = cal.alpha_of(p) as f64 * (1.0 + cal.ks_ta as f64 * dta);
            if !calibration_mode {
                let (i, conv) = (il_pattern(p), conversion_pattern(p));
                il[p] = cal.il_chess_c[2] as f64 * (2 * i - 1) as f64
                    - cal.il_chess_c[1] as f64 * conv as f64;
            }
            let kta = cal.kta_of(p) as f64;
            let kv = cal.kv_of(p) as f64;
            offset[p] = cal.offset[p] as f64 * (1.0 + kta * dta) * (1.0 + kv * (vdd - 3.3));
        }
        Encoder {
            key,
            gain,
            inv_gain: 1.0 / gain,
            gain_ram,
            vdd_raw,
            ptat_raw,
            vbe_raw,
            cp_raw,
            ir_cp_tgc: cal.tgc as f64 * ir_cp,
            ta4,
            ks,
            ct,
            corr,
            one_minus: 1.0 - ks[1] * 273.15,
            alpha,
            il,
            offset,
            calibration_mode,
            pixels,
        }
    }

    /// Write the aux words (gain, Vdd, PTAT, Vbe, the compensation pixels) into `ram`.
    fn write_aux(&self, ram: &mut [u16; PIXELS + AUX_WORDS]) {
        ram[PIXELS..].fill(0);
        ram[IDX_GAIN] = self.gain_ram as u16;
        ram[IDX_VDD] = self.vdd_raw as u16;
        ram[IDX_PTAT] = self.ptat_raw as u16;
        ram[IDX_VBE] = self.vbe_raw as u16;
        ram[IDX_CP_SP0] = self.cp_raw[0] as u16;
        ram[IDX_CP_SP1] = self.cp_raw[1] as u16;
    }

    /// The range (0–3) of a first-pass temperature `to1`, °C.
    fn range(&self, to1: f64) -> usize {
        let ct = &self.ct;
        if to1 < ct[1] {
            0
        } else if to1 < ct[2] {
            1
        } else if to1 < ct[3] {
            2
        } else {
            3
        }
    }

    /// The calculation's fourth-root steps in `f64`: the object temperature (K) that the
    /// compensated IR signal `ir` of a pixel of sensitivity `alpha` decodes to (emissivity 1,
    /// so the reflected temperature drops out and `taTr` = Ta⁴), with the first pass's range.
    /// First pass with the Sx approximation picks the range and the KsTo factor, second pass
    /// gives To.
    fn to_of_ir(&self, alpha: f64, ir: f64) -> (f64, usize) {
        let ks = &self.ks;
        let sx = (alpha.powi(3) * (ir + alpha * self.ta4))
            .max(0.0)
            .sqrt()
            .sqrt()
            * ks[1];
        let to1 = (ir / (alpha * self.one_minus + sx) + self.ta4)
            .max(0.0)
            .sqrt()
            .sqrt()
            - 273.15;
        let range = self.range(to1);
        let to = (ir / (alpha * self.corr[range] * (1.0 + ks[range] * (to1 - self.ct[range])))
            + self.ta4)
            .max(0.0)
            .sqrt()
            .sqrt();
        (to, range)
    }

    /// The compensated IR signal that decodes to `to_k`: the secant method on
    /// [`Self::to_of_ir`] (smooth and increasing), from the signal without the range terms,
    /// until the temperature is within `tol_k`.
    fn ir_for(&self, alpha: f64, to_k: f64, tol_k: f64) -> f64 {
        let f = |ir: f64| self.to_of_ir(alpha, ir).0 - to_k;
        let mut x0 = (to_k.powi(4) - self.ta4) * alpha;
        let mut x1 = x0 + 1.0;
        let (mut f0, mut f1) = (f(x0), f(x1));
        for _ in 0..40 {
            if f1 == f0 || f1.abs() < tol_k {
                break;
            }
            let x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
            (x0, f0) = (x1, f1);
            x1 = x2;
            f1 = f(x1);
        }
        x1
    }

    /// The raw word (unrounded) of pixel `p` for the compensated IR signal `ir`.
    #[inline]
    fn word_of_ir(&self, p: usize, ir: f64) -> f64 {
        let mut v = ir + self.ir_cp_tgc;
        if !self.calibration_mode {
            v -= self.il[p];
        }
        v += self.offset[p];
        v / self.gain
    }

    /// Return the raw pixel word whose exact inverse is `to_k`: the secant method solved to
    /// 1 nK, rounded to the ADC's counts.
    fn pixel_raw(&self, p: usize, to_k: f64) -> i16 {
        let ir = self.ir_for(self.alpha[p], to_k.max(1.0), 1e-9);
        clamp_i16(self.word_of_ir(p, ir))
    }

    /// [`Self::word_of_unit`] of the subpage's pixels `self.pixels[i]` for `unit[i]` (NaN:
    /// `None`) into `words[i]`. On x86-64 two pixels at a time with SSE2 (`sse2_words`), the
    /// same operations in the same order, so the same words.
    fn words_of_units(&self, unit: &[f64], words: &mut [Option<i16>]) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `sse2_words` needs SSE2 alone, which every x86-64 processor has (it is
            // part of the architecture's baseline).
            unsafe { self.sse2_words(unit, words) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        for ((&p, &u), w) in self.pixels.iter().zip(unit).zip(words) {
            *w = self.word_of_unit(p as usize, u);
        }
    }

    /// [`Self::words_of_units`] with SSE2: x = ((alpha·u + ir_cp_tgc) − il + offset)·(1/gain)
    /// for two pixels at once, then the same tests as [`Self::word_of_unit`] — NaN or
    /// |x| ≥ 1e9, the truncation (`CVTTPD2DQ`; exact below 2³¹), the distance from a tie —
    /// per lane. An odd last pixel goes through [`Self::word_of_unit`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "sse2")]
    fn sse2_words(&self, unit: &[f64], words: &mut [Option<i16>]) {
        use core::arch::x86_64::{
            _mm_add_pd, _mm_and_pd, _mm_castsi128_pd, _mm_cmpge_pd, _mm_cmpgt_pd, _mm_cmple_pd,
            _mm_cmplt_pd, _mm_cmpunord_pd, _mm_cvtepi32_pd, _mm_cvtsi128_si32, _mm_cvttpd_epi32,
            _mm_movemask_pd, _mm_mul_pd, _mm_or_pd, _mm_set_pd, _mm_set1_epi64x, _mm_set1_pd,
            _mm_srli_si128, _mm_sub_pd,
        };
        let abs_mask = _mm_castsi128_pd(_mm_set1_epi64x(i64::MAX));
        let (cp, inv_gain) = (_mm_set1_pd(self.ir_cp_tgc), _mm_set1_pd(self.inv_gain));
        let (big, half, guard, zero) = (
            _mm_set1_pd(1e9),
            _mm_set1_pd(0.5),
            _mm_set1_pd(TIE_GUARD),
            _mm_set1_pd(0.0),
        );
        let pairs = unit.len() / 2;
        for i in 0..pairs {
            let (a, b) = (2 * i, 2 * i + 1);
            let (pa, pb) = (self.pixels[a] as usize, self.pixels[b] as usize);
            let pair = |v: &[f64]| _mm_set_pd(v[pb], v[pa]);
            let u = _mm_set_pd(unit[b], unit[a]);
            let mut v = _mm_add_pd(_mm_mul_pd(pair(&self.alpha[..]), u), cp);
            if !self.calibration_mode {
                v = _mm_sub_pd(v, pair(&self.il[..]));
            }
            let x = _mm_mul_pd(_mm_add_pd(v, pair(&self.offset[..])), inv_gain);
            let bad = _mm_or_pd(
                _mm_cmpunord_pd(x, x),
                _mm_cmpge_pd(_mm_and_pd(x, abs_mask), big),
            );
            let whole = _mm_cvttpd_epi32(x);
            let frac = _mm_and_pd(_mm_sub_pd(x, _mm_cvtepi32_pd(whole)), abs_mask);
            let tie = _mm_cmple_pd(_mm_and_pd(_mm_sub_pd(frac, half), abs_mask), guard);
            let skip = _mm_movemask_pd(_mm_or_pd(bad, tie));
            let up = _mm_movemask_pd(_mm_cmpgt_pd(frac, half));
            let neg = _mm_movemask_pd(_mm_cmplt_pd(x, zero));
            let wholes = [
                _mm_cvtsi128_si32(whole),
                _mm_cvtsi128_si32(_mm_srli_si128::<4>(whole)),
            ];
            for (lane, k) in [a, b].into_iter().enumerate() {
                words[k] = if skip >> lane & 1 != 0 {
                    None
                } else {
                    let step = if neg >> lane & 1 != 0 { -1 } else { 1 };
                    let n = wholes[lane] as i64 + (up >> lane & 1) as i64 * step;
                    Some(n.clamp(-32768, 32766) as i16)
                };
            }
        }
        if unit.len() % 2 == 1 {
            let k = unit.len() - 1;
            words[k] = self.word_of_unit(self.pixels[k] as usize, unit[k]);
        }
    }

    /// [`Self::pixel_raw`], fast, or `None` where it cannot vouch for the word: the word of
    /// pixel `p` for `u`, the table's signal for a unit alpha (`alpha × u` is the signal: the
    /// calculation scales by alpha), taken unless the table has no smooth piece there (`u`
    /// NaN) or the word lies within [`TIE_GUARD`] counts of a rounding tie — there it and the
    /// secant method's could round apart.
    #[inline]
    fn word_of_unit(&self, p: usize, u: f64) -> Option<i16> {
        let mut v = self.alpha[p] * u + self.ir_cp_tgc;
        if !self.calibration_mode {
            v -= self.il[p];
        }
        let x = (v + self.offset[p]) * self.inv_gain;
        // Round half away from zero as `clamp_i16`, without a library call.
        if x.is_nan() || x.abs() >= 1e9 {
            return None;
        }
        let whole = x as i64;
        let frac = (x - whole as f64).abs();
        if (frac - 0.5).abs() <= TIE_GUARD {
            return None;
        }
        let n = whole + (frac > 0.5) as i64 * if x < 0.0 { -1 } else { 1 };
        Some(n.clamp(-32768, 32766) as i16)
    }
}

/// How close to a rounding tie (in ADC counts) the fast path's word must not come for it to be
/// taken: the secant method stops within 1 nK of the temperature, at most 6e-7 counts (a pixel
/// gives ≤ 4·alpha·T³ ≤ 600 counts/K up to 1000 K); the table's pieces are within 1e-8 counts,
/// and the product by 1/gain within 1e-11 counts of the quotient.
const TIE_GUARD: f64 = 1e-4;

/// The inverse calculation for a unit alpha, `u(To)` (the signal that decodes to `To` is
/// `alpha·u(To)`: the calculation depends on `ir/alpha` alone), as cubic pieces 1 K wide over
/// [`InverseTable::LO_K`, `InverseTable::HI_K`], each built the first time it is needed from
/// four points solved to the last bits. A piece across a range's corner (where the
/// calculation's slope jumps) is never used.
struct InverseTable {
    /// Ta⁴ and the constants it was built for (KsTo, CT).
    ta4_bits: u64,
    ks: [f64; 4],
    ct: [f64; 4],
    /// Per piece: the cubic's coefficients in the position within the piece (0–1); NaN not
    /// built yet; infinite: across a corner.
    pieces: Vec<[f64; 4]>,
}

impl InverseTable {
    const LO_K: f64 = 200.0;
    const HI_K: f64 = 1000.0;
    const STEP_K: f64 = 1.0;

    fn new() -> Self {
        InverseTable {
            ta4_bits: 0,
            ks: [0.0; 4],
            ct: [0.0; 4],
            pieces: Vec::new(),
        }
    }

    /// Forget the pieces unless they were built for `enc`'s Ta and calibration.
    fn prepare(&mut self, enc: &Encoder) {
        if self.ta4_bits != enc.ta4.to_bits() || self.ks != enc.ks || self.ct != enc.ct {
            self.ta4_bits = enc.ta4.to_bits();
            self.ks = enc.ks;
            self.ct = enc.ct;
            let n = ((Self::HI_K - Self::LO_K) / Self::STEP_K) as usize;
            self.pieces.clear();
            self.pieces.resize(n, [f64::NAN; 4]);
        }
    }

    /// `u(to_k)`, or `None` outside the table or on a piece across a corner.
    #[inline]
    fn unit_ir(&mut self, enc: &Encoder, to_k: f64) -> Option<f64> {
        let x = (to_k - Self::LO_K) / Self::STEP_K;
        if !(x >= 0.0 && x < self.pieces.len() as f64) {
            return None;
        }
        let i = x as usize;
        let s = x - i as f64;
        let mut c = self.pieces[i];
        if c[0].is_nan() {
            c = Self::piece(enc, Self::LO_K + i as f64 * Self::STEP_K);
            self.pieces[i] = c;
        }
        if c[0].is_infinite() {
            return None;
        }
        Some(c[0] + s * (c[1] + s * (c[2] + s * c[3])))
    }

    /// The cubic through `u` at four equally spaced points of the piece from `lo_k`.
    fn piece(enc: &Encoder, lo_k: f64) -> [f64; 4] {
        let mut u = [0.0; 4];
        let mut ranges = [0; 4];
        for (k, (u, range)) in u.iter_mut().zip(ranges.iter_mut()).enumerate() {
            let to = lo_k + Self::STEP_K * k as f64 / 3.0;
            *u = enc.ir_for(1.0, to, 1e-11);
            *range = enc.to_of_ir(1.0, *u).1;
        }
        if ranges[0] != ranges[3] {
            return [f64::INFINITY; 4];
        }
        // Newton's divided differences at s = 0, 1/3, 2/3, 1, then the monomial coefficients.
        let h = 1.0 / 3.0;
        let d1 = [(u[1] - u[0]) / h, (u[2] - u[1]) / h, (u[3] - u[2]) / h];
        let d2 = [(d1[1] - d1[0]) / (2.0 * h), (d1[2] - d1[1]) / (2.0 * h)];
        let d3 = (d2[1] - d2[0]) / (3.0 * h);
        // u(s) = u0 + d1₀ s + d2₀ s (s − h) + d3 s (s − h)(s − 2h).
        [
            u[0],
            d1[0] - d2[0] * h + d3 * 2.0 * h * h,
            d2[0] - d3 * 3.0 * h,
            d3,
        ]
    }
}

/// The bus to the virtual device: cheap to clone, every clone reaches the same device.
#[derive(Clone)]
pub struct VirtualBus(pub Rc<RefCell<VirtualMlx90640>>);

impl VirtualBus {
    /// Put `device` on a bus.
    pub fn new(device: VirtualMlx90640) -> Self {
        VirtualBus(Rc::new(RefCell::new(device)))
    }
}

/// The error of the virtual bus: an embedded-hal error kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusError(pub ErrorKind);

impl embedded_hal::i2c::Error for BusError {
    fn kind(&self) -> ErrorKind {
        self.0
    }
}

impl ErrorType for VirtualBus {
    type Error = BusError;
}

impl I2c for VirtualBus {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        if matches!(
            self.0.borrow().fault,
            Some(SensorFault::BusTimeout | SensorFault::BusStuckLow)
        ) {
            // A held-down line: the transfer never completes.
            core::future::pending::<()>().await;
        }
        self.0
            .borrow_mut()
            .transaction(address, operations)
            .map_err(BusError)
    }
}

impl RecoverBus for VirtualBus {
    async fn recover(&mut self) -> Result<(), BusStuck> {
        let mut dev = self.0.borrow_mut();
        dev.recover_bus();
        // A bus that times out without being held low stays as it is: recovery succeeds, the
        // next transfer times out again.
        Ok(())
    }
}

impl Clock for SimClock {
    fn now(&self) -> Millis {
        Millis(self.now_us() / 1000)
    }
}

/// The sensing pipeline's working memory on the heap (≈ 60 KB).
pub struct HeapBuffers(pub Box<Buffers>);

impl HeapBuffers {
    /// Zeroed buffers.
    pub fn new() -> Self {
        HeapBuffers(Box::new(Buffers::new()))
    }
}

impl Default for HeapBuffers {
    fn default() -> Self {
        Self::new()
    }
}

impl Storage for HeapBuffers {
    fn parts(&mut self) -> Parts<'_> {
        self.0.parts()
    }

    fn image(&self) -> &Image {
        self.0.image()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use thermorph::mlx90640::{ReadingPattern, RefreshRate, Resolution};

    fn device(seed: u64, resolution: Resolution, pattern: ReadingPattern) -> VirtualMlx90640 {
        let eeprom = crate::sensor::eeprom::realistic(seed).encode().unwrap();
        let mut dev = VirtualMlx90640::new(eeprom, SimClock::new(), seed).unwrap();
        dev.set_control(Control(POWER_ON_CONTROL).with(RefreshRate::Hz8, resolution, pattern));
        dev
    }

    /// The fast encoder (table, tie guard) gives the secant method's words, word for word:
    /// every resolution and pattern, noise on, temperatures across the table (and outside it)
    /// with the range corners near 273 K, 433 K and 593 K, two sensor temperatures.
    #[test]
    fn fast_encoding_matches_the_secant_method_word_for_word() {
        let mut rng = Rng::new(99);
        let (mut words, mut by_secant) = (0u64, 0u64);
        for (seed, resolution, pattern, ta_k) in [
            (1, Resolution::Bits18, ReadingPattern::Chess, DEFAULT_TA_K),
            (2, Resolution::Bits16, ReadingPattern::Chess, 298.15),
            (
                3,
                Resolution::Bits19,
                ReadingPattern::Interleaved,
                DEFAULT_TA_K,
            ),
            (4, Resolution::Bits17, ReadingPattern::Interleaved, 318.0),
        ] {
            // Two devices of one seed draw the same noise.
            let mut fast = device(seed, resolution, pattern);
            let mut exact = device(seed, resolution, pattern);
            for dev in [&mut fast, &mut exact] {
                dev.ta_k = ta_k;
                dev.noise_k = 0.3;
            }
            for round in 0..100 {
                let field: [f32; PIXELS] = core::array::from_fn(|p| match round % 4 {
                    0 => (150.0 + 950.0 * rng.uniform()) as f32,
                    1 => (263.0 + 310.0 * rng.uniform()) as f32,
                    2 => ([273.15, 433.15, 593.15][p % 3] + 4.0 * (rng.uniform() - 0.5)) as f32,
                    _ => (295.0 + 70.0 * rng.uniform()) as f32,
                });
                fast.field_k = field;
                exact.field_k = field;
                let sp = (round % 2) as u8;
                fast.encode_subpage(sp);
                exact.encode_subpage_exact(sp);
                assert_eq!(fast.ram, exact.ram, "seed {seed}, round {round}");
                words += (PIXELS / 2) as u64;
            }
            by_secant += fast.exact_pixels();
        }
        // Outside the table (a quarter of the first kind of field) and near the corners the
        // secant method finds the words; elsewhere the table does.
        assert!(
            by_secant < words / 5,
            "{by_secant} of {words} words by the secant method"
        );
    }

    #[test]
    fn the_table_is_used_for_the_camera_s_temperatures() {
        let mut dev = device(1, Resolution::Bits18, ReadingPattern::Chess);
        let mut rng = Rng::new(5);
        for k in 0..20 {
            dev.field_k = core::array::from_fn(|_| (290.0 + 80.0 * rng.uniform()) as f32);
            dev.encode_subpage((k % 2) as u8);
        }
        // A tie within 1e-4 counts, or a piece across a corner: a few in 7680 words.
        assert!(
            dev.exact_pixels() < 20,
            "{} by the secant method",
            dev.exact_pixels()
        );
    }
}
