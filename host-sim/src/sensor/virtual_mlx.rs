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
//! Injectable faults ([`Fault`]): NACK, bus timeout (a transfer that never completes), a bus
//! held low (every transfer hangs until a bus recovery, [`VirtualBus`]'s
//! [`RecoverBus`] implementation, clocks it free), stuck (no new data), 0x7FFF corruption, and
//! a frozen frame (RAM stops changing while the new-data flag keeps coming). A power cycle
//! ([`VirtualMlx90640::power_cycle`]) puts the control register back to its 2 Hz default.
//!
//! Bus time: every transfer advances the simulated clock by its duration at 400 kHz
//! (9 bit times per byte), so reading a subpage costs ≈ 40 ms as on the board.

use std::cell::RefCell;
use std::rc::Rc;

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
pub enum Fault {
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
    fault: Option<Fault>,
    rng: Rng,
    measurements: u64,
    recoveries: u64,
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
            rng: Rng::new(seed),
            measurements: 0,
            recoveries: 0,
        })
    }

    /// Return the calibration the device inverts.
    pub fn calibration(&self) -> &Calibration {
        &self.cal
    }

    /// Show `fault` from now on (`None` heals the device).
    pub fn set_fault(&mut self, fault: Option<Fault>) {
        self.fault = fault;
    }

    /// Return the active fault.
    pub fn fault(&self) -> Option<Fault> {
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
        if self.fault == Some(Fault::BusStuckLow) {
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
        if self.fault == Some(Fault::Stuck) {
            return;
        }
        let sp = self.next_subpage;
        self.next_subpage ^= 1;
        self.measurements += 1;
        if self.fault != Some(Fault::Frozen) {
            self.encode_subpage(sp);
        }
        if self.fault == Some(Fault::Corrupt) {
            self.ram[PIXELS] = 0x7FFF; // aux word 0 (Vbe)
            self.ram[(2 + sp as usize) * 32] = 0x7FFF; // first pixel of a row of this parity
        }
        self.status = (self.status & !(Status::SUBPAGE | 0x6)) | Status::NEW_DATA | sp as u16;
    }

    /// Encode the current field, Ta and Vdd into subpage `sp`'s RAM words.
    pub fn encode_subpage(&mut self, sp: u8) {
        let ctrl = self.control();
        let enc = Encoder::new(&self.cal, ctrl, sp, self.ta_k, self.vdd_v);
        self.ram[PIXELS..].fill(0);
        self.ram[IDX_GAIN] = enc.gain_ram as u16;
        self.ram[IDX_VDD] = enc.vdd_raw as u16;
        self.ram[IDX_PTAT] = enc.ptat_raw as u16;
        self.ram[IDX_VBE] = enc.vbe_raw as u16;
        self.ram[IDX_CP_SP0] = enc.cp_raw[0] as u16;
        self.ram[IDX_CP_SP1] = enc.cp_raw[1] as u16;
        let pattern = ctrl.pattern();
        for p in 0..PIXELS {
            if !pixel_in_subpage(p, pattern, sp) {
                continue;
            }
            let mut t = self.field_k[p] as f64;
            if self.noise_k > 0.0 {
                t += self.noise_k * self.rng.gauss();
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
        self.advance();
        if self.fault == Some(Fault::Nack) || address != thermorph::mlx90640::ADDRESS {
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
                    for (i, pair) in buf.chunks_exact_mut(2).enumerate() {
                        let w = self.read_word(start.wrapping_add(i as u16));
                        pair.copy_from_slice(&w.to_be_bytes());
                    }
                    pointer = Some(start.wrapping_add((buf.len() / 2) as u16));
                }
            }
        }
        Ok(())
    }
}

/// The inverse of the Melexis calculation for one subpage: raw words from temperatures.
struct Encoder<'a> {
    cal: &'a Calibration,
    gain: f64,
    gain_ram: i16,
    vdd_raw: i16,
    ptat_raw: i16,
    vbe_raw: i16,
    cp_raw: [i16; 2],
    /// Ta and Vdd as the decoder will compute them from the rounded words.
    ta_c: f64,
    vdd: f64,
    ir_cp_tgc: f64,
    calibration_mode: bool,
    ta4: f64,
}

fn clamp_i16(x: f64) -> i16 {
    // 0x7FFF is the library's "not written" marker, so saturate one below it.
    x.round().clamp(-32768.0, 32766.0) as i16
}

impl<'a> Encoder<'a> {
    fn new(cal: &'a Calibration, ctrl: Control, sp: u8, ta_k: f64, vdd_v: f64) -> Self {
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
        Encoder {
            cal,
            gain,
            gain_ram,
            vdd_raw,
            ptat_raw,
            vbe_raw,
            cp_raw,
            ta_c,
            vdd,
            ir_cp_tgc: cal.tgc as f64 * ir_cp,
            calibration_mode,
            ta4,
        }
    }

    /// The calculation's fourth-root steps in `f64`: the object temperature (K) that the
    /// compensated IR signal `ir` of a pixel of sensitivity `alpha` decodes to (emissivity 1,
    /// so the reflected temperature drops out and `taTr` = Ta⁴). First pass with the Sx
    /// approximation picks the range and the KsTo factor, second pass gives To.
    fn to_of_ir(&self, alpha: f64, ir: f64) -> f64 {
        let cal = self.cal;
        let ks = |i: usize| cal.ks_to[i] as f64;
        let ct = |i: usize| cal.ct[i] as f64;
        let corr = {
            let r2 = 1.0 + ks(1) * ct(2);
            [
                1.0 / (1.0 + ks(0) * 40.0),
                1.0,
                r2,
                r2 * (1.0 + ks(2) * (ct(3) - ct(2))),
            ]
        };
        let sx = (alpha.powi(3) * (ir + alpha * self.ta4))
            .max(0.0)
            .sqrt()
            .sqrt()
            * ks(1);
        let to1 = (ir / (alpha * (1.0 - ks(1) * 273.15) + sx) + self.ta4)
            .max(0.0)
            .sqrt()
            .sqrt()
            - 273.15;
        let range = if to1 < ct(1) {
            0
        } else if to1 < ct(2) {
            1
        } else if to1 < ct(3) {
            2
        } else {
            3
        };
        (ir / (alpha * corr[range] * (1.0 + ks(range) * (to1 - ct(range)))) + self.ta4)
            .max(0.0)
            .sqrt()
            .sqrt()
    }

    /// The compensated IR signal that decodes to `to_k`: the secant method on
    /// [`Self::to_of_ir`] (smooth and increasing), from the signal without the range terms.
    fn ir_for(&self, alpha: f64, to_k: f64) -> f64 {
        let f = |ir: f64| self.to_of_ir(alpha, ir) - to_k;
        let mut x0 = (to_k.powi(4) - self.ta4) * alpha;
        let mut x1 = x0 + 1.0;
        let (mut f0, mut f1) = (f(x0), f(x1));
        for _ in 0..40 {
            if f1 == f0 || f1.abs() < 1e-9 {
                break;
            }
            let x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
            (x0, f0) = (x1, f1);
            x1 = x2;
            f1 = f(x1);
        }
        x1
    }

    /// Return the raw pixel word that decodes closest to `to_k`.
    fn pixel_raw(&self, p: usize, to_k: f64) -> i16 {
        let cal = self.cal;
        let dta = self.ta_c - 25.0;
        let alpha = cal.alpha_of(p) as f64 * (1.0 + cal.ks_ta as f64 * dta);
        let ir = self.ir_for(alpha, to_k.max(1.0));
        let kta = cal.kta_of(p) as f64;
        let kv = cal.kv_of(p) as f64;
        let mut v = ir + self.ir_cp_tgc;
        if !self.calibration_mode {
            let (il, conv) = (il_pattern(p), conversion_pattern(p));
            v -= cal.il_chess_c[2] as f64 * (2 * il - 1) as f64
                - cal.il_chess_c[1] as f64 * conv as f64;
        }
        v += cal.offset[p] as f64 * (1.0 + kta * dta) * (1.0 + kv * (self.vdd - 3.3));
        clamp_i16(v / self.gain)
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
            Some(Fault::BusTimeout | Fault::BusStuckLow)
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
