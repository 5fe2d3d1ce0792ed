//! The emulated STM32F446's Cortex-M4F core: unicorn (GPL-2.0, built only with `--features
//! pil`) executes the instructions; this module owns what unicorn leaves to its user on an
//! M-profile core — the memory map, time, sleep, and exceptions.
//!
//! - **Memory.** 512 KiB of flash at 0x0800_0000 (and its boot alias at 0), 128 KiB of SRAM at
//!   0x2000_0000 (kept across a chip reset, as on the board), the System Control Space
//!   ([`Nvic`]) at 0xE000_E000, and every peripheral window (0x4000_0000–0x4007_FFFF,
//!   0x5000_0000, 0xE004_2000) forwarded to the chip's [`Bus`]. An access to nothing is a bus
//!   fault: recorded ([`Core::bus_faults`]), the read as 0, so a run shows which register the
//!   models lack rather than hanging.
//! - **Time.** The core's time is its instructions at the system clock the RCC gives (one
//!   instruction a cycle: the Cortex-M4's pipeline does most in one; flash wait states and
//!   divides are not counted). A block hook counts each translated block's instructions;
//!   runs are sliced at the next peripheral event, so every register access sees the time
//!   within a slice.
//! - **Sleep.** `wfe` with the event register clear sleeps: the time skips to the next
//!   peripheral event or an interrupt that would be taken (ARMv7-M B1.5.18); `sev` sets the
//!   event register. unicorn executes both as no-ops: code hooks at every `wfe`/`sev` in the
//!   ELF's code do the rest.
//! - **Exceptions** (ARMv7-M B1.5.6–B1.5.8): the [`Nvic`] chooses; entry pushes the basic
//!   frame (R0–R3, R12, LR, the return address, xPSR with its alignment bit) or, with
//!   CONTROL.FPCA, the extended one (S0–S15 and FPSCR too: the state lazy stacking would
//!   write, written at entry, and FPCAR set to it), sets LR to EXC_RETURN and jumps to the
//!   vector; a branch to EXC_RETURN (a fetch at 0xFFFF_FFxx) pops it. unicorn's own M-profile
//!   exception logic is never entered: to it the core stays in thread mode (IPSR reads 0).

use std::collections::HashMap;

use unicorn_engine::unicorn_const::{
    Arch, ArmCpuModel, HookType, MemType, Mode, Prot, TlbEntry, TlbType, uc_error,
};
use unicorn_engine::{RegisterARM, Unicorn};

use super::nvic::{Masks, Nvic, SCS_BASE};
use super::{Bus, Memory, Size, Time};

pub use super::{FLASH_BASE, FLASH_BYTES, SRAM_BASE, SRAM_BYTES};

/// The peripheral windows forwarded to the bus: APB1, APB2, AHB1 (with the backup SRAM),
/// AHB2, and the DBGMCU.
const WINDOWS: [(u32, u32); 4] = [
    (0x4000_0000, 0x0008_0000),
    (0x5000_0000, 0x0006_1000),
    (0xE000_0000, 0x0001_0000),
    (0xE004_2000, 0x0000_1000),
];
/// The longest slice the core runs without looking at the interrupts, instructions (≈ 91 µs
/// at 180 MHz). A slice also ends at the next peripheral event and after a write that makes
/// an interrupt takeable; with an interrupt pending but masked it is [`MASKED_SLICE`] at most.
const MAX_SLICE: u64 = 16_384;
/// The longest slice while an interrupt is pending but masked, instructions (≈ 1.4 µs at
/// 180 MHz: the latency a `cpsie` or an `msr` to PRIMASK or BASEPRI can add to it; the
/// instructions that open the masks are not watched).
const MASKED_SLICE: u64 = 256;
/// Branches to at or above this are exception returns (EXC_RETURN's prefix).
const EXC_RETURN_MIN: u32 = 0xF000_0000;

/// Why the core could not go on.
#[derive(Debug, thiserror::Error)]
pub enum CpuError {
    /// unicorn refused or stopped on something the core cannot continue from.
    #[error("the emulated core stopped at pc {pc:#010x}: {err:?}")]
    Core {
        /// The program counter then.
        pc: u32,
        /// unicorn's error.
        err: uc_error,
    },
    /// A return from an exception that is not active, or with a bad EXC_RETURN.
    #[error(
        "an exception return {exc_return:#010x} with exception {active} active (pc {pc:#010x})"
    )]
    BadReturn {
        /// The EXC_RETURN value.
        exc_return: u32,
        /// The innermost active exception.
        active: u16,
        /// Where it was taken from.
        pc: u32,
    },
    /// The image does not fit the chip's flash.
    #[error("{0}")]
    Image(String),
}

/// A bus access to nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusFault {
    /// The address.
    pub addr: u32,
    /// A write (else a read).
    pub write: bool,
}

/// What the core keeps beside unicorn's registers.
struct State {
    bus: Option<Box<dyn Bus>>,
    nvic: Nvic,
    /// Chip time at the start of the present slice.
    slice_start: Time,
    /// Instructions into the present slice (counted at each block's start).
    slice_instructions: u64,
    /// The slice ends after this many.
    slice_limit: u64,
    /// The system clock during the slice, Hz.
    sysclk_hz: u32,
    /// The event register.
    event: bool,
    /// The core reached `wfe` with the event register clear: it sleeps there.
    sleeping: bool,
    /// The `wfe` it sleeps at (unicorn stops before executing it; waking steps past it).
    wfe_at: u32,
    /// Instructions in each translated block.
    blocks: Blocks,
    /// Accesses to nothing.
    faults: Vec<BusFault>,
    /// Every instruction run since power-up.
    instructions: u64,
    /// An interrupt may have become takeable in a register write: end the slice.
    recheck: bool,
    /// When the chip reset.
    resets: Vec<Time>,
    /// Slices run and sleeps skipped (the emulation's own cost: [`Core::stats`]).
    slices: u64,
    sleeps: u64,
}

impl State {
    /// Hand the bus's interrupt lines to the NVIC (SEVONPEND: a newly pending one sets the
    /// event register).
    fn sync_lines(&mut self) {
        let nvic = &mut self.nvic;
        let mut woke = false;
        self.bus
            .as_ref()
            .expect("the bus is present")
            .irqs(&mut |irq, high| woke |= nvic.set_line(irq, high));
        if woke && self.nvic.sev_on_pend() {
            self.event = true;
        }
    }

    fn now(&self) -> Time {
        self.slice_start + super::Clocks::time_of(self.slice_instructions, self.sysclk_hz)
    }
}

/// Instructions in each translated block, by its address and size: a table by halfword for
/// the flash and its alias (where the code is; looked up at every block the core runs), a map
/// for anywhere else.
#[derive(Default)]
struct Blocks {
    /// By `(address % FLASH_BYTES) / 2`: `size << 16 | instructions`, 0 for none yet.
    flash: Vec<u32>,
    other: HashMap<(u32, u32), u32>,
}

impl Blocks {
    fn slot(addr: u32, size: u32) -> Option<usize> {
        let in_flash = addr < FLASH_BYTES || (FLASH_BASE..FLASH_BASE + FLASH_BYTES).contains(&addr);
        (in_flash && size < 1 << 16).then_some(((addr % FLASH_BYTES) / 2) as usize)
    }

    fn get(&self, addr: u32, size: u32) -> Option<u32> {
        match Self::slot(addr, size) {
            Some(i) => {
                let v = *self.flash.get(i)?;
                (v != 0 && v >> 16 == size).then_some(v & 0xFFFF)
            }
            None => self.other.get(&(addr, size)).copied(),
        }
    }

    fn insert(&mut self, addr: u32, size: u32, n: u32) {
        match Self::slot(addr, size).filter(|_| n < 1 << 16) {
            Some(i) => {
                if self.flash.is_empty() {
                    self.flash = vec![0; (FLASH_BYTES / 2) as usize];
                }
                self.flash[i] = size << 16 | n;
            }
            None => {
                self.other.insert((addr, size), n);
            }
        }
    }
}

/// The core's interrupt masks now.
fn masks_of(uc: &Unicorn<'_, State>) -> Masks {
    let reg = |r| uc.reg_read(r).unwrap_or(0) as u32;
    Masks {
        primask: reg(RegisterARM::PRIMASK) & 1 != 0,
        faultmask: reg(RegisterARM::FAULTMASK) & 1 != 0,
        basepri: reg(RegisterARM::BASEPRI) as u8,
    }
}

/// Hand the bus's lines to the NVIC and say whether an exception is now to be taken.
fn interrupt_due(uc: &mut Unicorn<'_, State>, addr: u32) -> bool {
    let masks = masks_of(uc);
    let st = uc.get_data_mut();
    // Only the lines the write can have moved.
    let nvic = &mut st.nvic;
    let mut woke = false;
    st.bus
        .as_ref()
        .expect("the bus is present")
        .irqs_after_write(addr, &mut |irq, high| woke |= nvic.set_line(irq, high));
    if woke && st.nvic.sev_on_pend() {
        st.event = true;
    }
    if st.nvic.to_take(masks).is_some() {
        return true;
    }
    // Pending but masked (PRIMASK in a critical section, BASEPRI, a handler's priority): the
    // rest of the slice is short, so that it is taken soon after the masks open.
    if st.nvic.highest_pending().is_some() {
        st.slice_limit = st.slice_limit.min(st.slice_instructions + MASKED_SLICE);
    }
    false
}

/// The memories through unicorn, for the bus's DMA and the flash's programming.
struct UcMemory<'u, 'a>(&'u mut Unicorn<'a, State>);

impl Memory for UcMemory<'_, '_> {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> bool {
        self.0.mem_read(u64::from(addr), buf).is_ok()
    }

    fn write(&mut self, addr: u32, bytes: &[u8]) -> bool {
        // The flash and its alias are one array: keep both copies alike.
        let ok = self.0.mem_write(u64::from(addr), bytes).is_ok();
        if (FLASH_BASE..FLASH_BASE + FLASH_BYTES).contains(&addr) {
            let _ = self.0.mem_write(u64::from(addr - FLASH_BASE), bytes);
        }
        ok
    }
}

/// Run `f` with the bus taken out of the core's state (so it can reach the memories).
fn with_bus<R>(
    uc: &mut Unicorn<'_, State>,
    f: impl FnOnce(&mut dyn Bus, &mut UcMemory<'_, '_>, Time) -> R,
) -> R {
    let now = uc.get_data().now();
    let mut bus = uc.get_data_mut().bus.take().expect("the bus is present");
    let r = f(bus.as_mut(), &mut UcMemory(uc), now);
    uc.get_data_mut().bus = Some(bus);
    r
}

/// What looks at the chip's memories just before a reset takes effect ([`Core::on_reset`]).
pub type ResetHook = Box<dyn FnMut(&mut dyn Memory)>;

/// The emulated core with its chip.
pub struct Core {
    uc: Unicorn<'static, State>,
    /// Called before each chip reset (a probe's last look at the RAM).
    reset_hook: Option<ResetHook>,
}

impl Core {
    /// A core on `bus` with `image` (segments `(address, bytes)`, the ELF's loadable ones) in
    /// its flash, its `wfe`/`sev` instructions found in `code` (executable ranges `(address,
    /// bytes)`), held at reset until [`Core::reset`].
    pub fn new(
        bus: Box<dyn Bus>,
        image: &[(u32, Vec<u8>)],
        code: &[(u32, Vec<u8>)],
    ) -> Result<Core, CpuError> {
        let state = State {
            bus: Some(bus),
            nvic: Nvic::new(),
            slice_start: 0,
            slice_instructions: 0,
            slice_limit: MAX_SLICE,
            sysclk_hz: super::Clocks::RESET.sysclk_hz,
            event: false,
            sleeping: false,
            wfe_at: 0,
            blocks: Blocks::default(),
            faults: Vec::new(),
            instructions: 0,
            recheck: false,
            resets: Vec::new(),
            slices: 0,
            sleeps: 0,
        };
        let core_err = |err| CpuError::Core { pc: 0, err };
        let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB | Mode::MCLASS, state)
            .map_err(core_err)?;
        uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M4 as i32)
            .map_err(core_err)?;
        let rx = Prot::READ | Prot::EXEC;
        uc.mem_map(u64::from(FLASH_BASE), u64::from(FLASH_BYTES), rx)
            .map_err(core_err)?;
        uc.mem_map(0, u64::from(FLASH_BYTES), rx)
            .map_err(core_err)?;
        // SRAM holds no code (the ELF's code is in flash): mapped without execute.
        uc.mem_map(
            u64::from(SRAM_BASE),
            u64::from(SRAM_BYTES),
            Prot::READ | Prot::WRITE,
        )
        .map_err(core_err)?;
        // The erased flash reads all ones.
        let erased = vec![0xFFu8; FLASH_BYTES as usize];
        uc.mem_write(u64::from(FLASH_BASE), &erased)
            .map_err(core_err)?;
        uc.mem_write(0, &erased).map_err(core_err)?;
        for (addr, bytes) in image {
            let end = u64::from(*addr) + bytes.len() as u64;
            if *addr < FLASH_BASE || end > u64::from(FLASH_BASE + FLASH_BYTES) {
                return Err(CpuError::Image(format!(
                    "a segment at {addr:#010x} ({} bytes) is outside the STM32F446's flash \
                     (0x08000000, 512 KiB)",
                    bytes.len()
                )));
            }
            let mut mem = UcMemory(&mut uc);
            mem.write(*addr, bytes);
        }
        map_windows(&mut uc).map_err(core_err)?;
        fast_sram_stores(&mut uc).map_err(core_err)?;
        // Flash writes go to the bus (its interface programs the array).
        uc.add_mem_hook(
            HookType::MEM_WRITE_PROT,
            u64::from(FLASH_BASE),
            u64::from(FLASH_BASE + FLASH_BYTES - 1),
            |uc, _t: MemType, addr, size, value| {
                let size = Size::of(size as u32).unwrap_or(Size::Word);
                let ok = with_bus(uc, |bus, mem, now| {
                    bus.write(addr as u32, size, value as u32, now, mem)
                });
                if !ok {
                    uc.get_data_mut().faults.push(BusFault {
                        addr: addr as u32,
                        write: true,
                    });
                }
                true
            },
        )
        .map_err(core_err)?;
        uc.add_block_hook(1, 0, |uc, addr, size| {
            let n = match uc.get_data().blocks.get(addr as u32, size) {
                Some(n) => n,
                None => {
                    let mut buf = vec![0u8; size as usize];
                    let n = if uc.mem_read(addr, &mut buf).is_ok() {
                        thumb_instructions(&buf)
                    } else {
                        1
                    };
                    uc.get_data_mut().blocks.insert(addr as u32, size, n);
                    n
                }
            };
            let s = uc.get_data_mut();
            s.slice_instructions += u64::from(n);
            s.instructions += u64::from(n);
            if s.slice_instructions >= s.slice_limit || s.recheck {
                let _ = uc.emu_stop();
            }
        })
        .map_err(core_err)?;
        for (base, bytes) in code {
            for (i, pair) in bytes.chunks_exact(2).enumerate() {
                let at = u64::from(*base) + 2 * i as u64;
                match u16::from_le_bytes([pair[0], pair[1]]) {
                    // WFE: sleep unless the event register is set (which it clears).
                    0xBF20 => {
                        uc.add_code_hook(at, at, |uc, addr, _| {
                            let s = uc.get_data_mut();
                            if s.event {
                                s.event = false;
                            } else {
                                s.sleeping = true;
                                s.wfe_at = addr as u32;
                                let _ = uc.emu_stop();
                            }
                        })
                        .map_err(core_err)?;
                    }
                    // SEV.
                    0xBF40 => {
                        uc.add_code_hook(at, at, |uc, _, _| uc.get_data_mut().event = true)
                            .map_err(core_err)?;
                    }
                    _ => {}
                }
            }
        }
        Ok(Core {
            uc,
            reset_hook: None,
        })
    }

    /// The chip's reset: the core takes SP and PC from the vector table at the flash's base
    /// (the boot alias), every register and the NVIC as after reset. SRAM is kept.
    pub fn reset(&mut self) -> Result<(), CpuError> {
        let sp = self.read_u32(FLASH_BASE)?;
        let pc = self.read_u32(FLASH_BASE + 4)?;
        let st = self.uc.get_data_mut();
        st.nvic = Nvic::new();
        st.event = false;
        st.sleeping = false;
        let uc = &mut self.uc;
        let w = |uc: &mut Unicorn<'static, State>, r: RegisterARM, v: u32| {
            uc.reg_write(r, u64::from(v))
                .map_err(|err| CpuError::Core { pc, err })
        };
        for r in [
            RegisterARM::R0,
            RegisterARM::R1,
            RegisterARM::R2,
            RegisterARM::R3,
            RegisterARM::R12,
        ] {
            w(uc, r, 0)?;
        }
        w(uc, RegisterARM::CONTROL, 0)?;
        w(uc, RegisterARM::PRIMASK, 0)?;
        w(uc, RegisterARM::BASEPRI, 0)?;
        w(uc, RegisterARM::FAULTMASK, 0)?;
        w(uc, RegisterARM::MSP, sp)?;
        w(uc, RegisterARM::SP, sp)?;
        w(uc, RegisterARM::LR, 0xFFFF_FFFF)?;
        w(uc, RegisterARM::XPSR, 1 << 24)?;
        w(uc, RegisterARM::PC, pc & !1)?;
        Ok(())
    }

    /// The chip's time now.
    pub fn now(&self) -> Time {
        self.uc.get_data().now()
    }

    /// Instructions run since power-up.
    pub fn instructions(&self) -> u64 {
        self.uc.get_data().instructions
    }

    /// Accesses to nothing so far.
    pub fn bus_faults(&self) -> &[BusFault] {
        &self.uc.get_data().faults
    }

    /// The interrupt controller.
    pub fn nvic(&self) -> &Nvic {
        &self.uc.get_data().nvic
    }

    /// The chip's peripherals.
    pub fn bus(&self) -> &dyn Bus {
        self.uc
            .get_data()
            .bus
            .as_deref()
            .expect("the bus is present")
    }

    /// The chip's peripherals, to drive their outside (pins, bytes, the sensor).
    pub fn bus_mut(&mut self) -> &mut dyn Bus {
        self.uc
            .get_data_mut()
            .bus
            .as_deref_mut()
            .expect("the bus is present")
    }

    /// The chip's peripherals as the type they were built as (None: another type).
    pub fn bus_as<T: Bus>(&self) -> Option<&T> {
        let any: &dyn std::any::Any = self.bus();
        any.downcast_ref::<T>()
    }

    /// [`Core::bus_as`], mutable: to drive the chip's outside.
    pub fn bus_as_mut<T: Bus>(&mut self) -> Option<&mut T> {
        let any: &mut dyn std::any::Any = self.bus_mut();
        any.downcast_mut::<T>()
    }

    /// A core register.
    pub fn reg(&self, r: RegisterARM) -> u32 {
        self.uc.reg_read(r).unwrap_or(0) as u32
    }

    /// Read a word of memory (SRAM or flash).
    pub fn read_u32(&self, addr: u32) -> Result<u32, CpuError> {
        let mut b = [0u8; 4];
        self.uc
            .mem_read(u64::from(addr), &mut b)
            .map_err(|err| CpuError::Core { pc: addr, err })?;
        Ok(u32::from_le_bytes(b))
    }

    /// Read bytes of memory (SRAM or flash): the RTT buffers, the flash's record.
    pub fn read_bytes(&self, addr: u32, buf: &mut [u8]) -> Result<(), CpuError> {
        self.uc
            .mem_read(u64::from(addr), buf)
            .map_err(|err| CpuError::Core { pc: addr, err })
    }

    /// Write bytes of SRAM (the RTT buffers' read pointers).
    pub fn write_bytes(&mut self, addr: u32, bytes: &[u8]) -> Result<(), CpuError> {
        self.uc
            .mem_write(u64::from(addr), bytes)
            .map_err(|err| CpuError::Core { pc: addr, err })
    }

    /// Call `hook` with the chip's memories just before each reset the chip takes (a watchdog,
    /// SYSRESETREQ) while it runs: what a probe attached would still read before the start-up
    /// code initialises the RAM again (the RTT buffers). One hook: a second call replaces it.
    pub fn on_reset(&mut self, hook: ResetHook) {
        self.reset_hook = Some(hook);
    }

    /// Whether the core sleeps (at `wfe`, waiting for an event).
    pub fn sleeping(&self) -> bool {
        self.uc.get_data().sleeping
    }

    /// Run the chip until its time reaches `until`.
    pub fn run_until(&mut self, until: Time) -> Result<(), CpuError> {
        while self.now() < until {
            self.sync()?;
            if self.take_reset() {
                if let Some(hook) = self.reset_hook.as_mut() {
                    hook(&mut UcMemory(&mut self.uc));
                }
                self.reset()?;
                continue;
            }
            let masks = self.masks();
            if let Some(e) = self.uc.get_data().nvic.to_take(masks) {
                self.wake()?;
                self.enter(e)?;
                continue;
            }
            if self.uc.get_data().sleeping {
                if self.uc.get_data().event {
                    // SEVONPEND (or an event set meanwhile) wakes it.
                    self.uc.get_data_mut().event = false;
                    self.wake()?;
                } else {
                    self.sleep_until(until)?;
                }
                continue;
            }
            self.slice(until)?;
        }
        // The peripherals stand at the time reached too: what the harness gives them next
        // (bytes on a receive line, a pin's level) starts from there.
        self.sync()?;
        Ok(())
    }

    /// A system reset the chip asks for (a watchdog) or the core did (SYSRESETREQ): its
    /// time is recorded ([`Core::resets`]).
    fn take_reset(&mut self) -> bool {
        let now = self.now();
        let st = self.uc.get_data_mut();
        let bus = st.bus.as_mut().expect("the bus is present");
        let reset = if st.nvic.take_reset_request() {
            bus.software_reset();
            true
        } else {
            bus.take_reset()
        };
        if reset {
            st.resets.push(now);
        }
        reset
    }

    /// Slices the core ran and sleeps it skipped since power-up: what the emulation's speed
    /// goes by.
    pub fn stats(&self) -> (u64, u64) {
        let st = self.uc.get_data();
        (st.slices, st.sleeps)
    }

    /// When the chip reset (not counting the power-up), in its time.
    pub fn resets(&self) -> &[Time] {
        &self.uc.get_data().resets
    }

    /// Advance the bus to now, hand its interrupt lines to the NVIC, and follow the system
    /// clock.
    fn sync(&mut self) -> Result<(), CpuError> {
        let now = self.now();
        with_bus(&mut self.uc, |bus, mem, now| bus.advance(now, mem));
        let st = self.uc.get_data_mut();
        let clocks = st.bus.as_ref().expect("the bus is present").clocks();
        st.nvic.advance(now, &clocks);
        st.sync_lines();
        // A new system clock starts a new slice at the present time.
        if clocks.sysclk_hz != st.sysclk_hz {
            st.slice_start = now;
            st.slice_instructions = 0;
            st.sysclk_hz = clocks.sysclk_hz;
        }
        Ok(())
    }

    fn masks(&self) -> Masks {
        masks_of(&self.uc)
    }

    /// Wake from `wfe`: it completes (the core goes on after it).
    fn wake(&mut self) -> Result<(), CpuError> {
        let st = self.uc.get_data_mut();
        if !st.sleeping {
            return Ok(());
        }
        st.sleeping = false;
        let at = st.wfe_at;
        if self.reg(RegisterARM::PC) == at {
            self.uc
                .reg_write(RegisterARM::PC, u64::from(at + 2))
                .map_err(|err| CpuError::Core { pc: at, err })?;
        }
        Ok(())
    }

    /// Sleep at `wfe`: skip from event to event of the peripherals and SysTick until one
    /// makes an exception takeable, sets the event register, or resets the chip, or `until`.
    /// The interrupt masks cannot change while the core sleeps.
    fn sleep_until(&mut self, until: Time) -> Result<(), CpuError> {
        let masks = self.masks();
        loop {
            // The bus's own events that wake nothing, at once.
            let st = self.uc.get_data();
            let now = st.now();
            let clocks = st.bus.as_ref().expect("the bus is present").clocks();
            let systick = st.nvic.next_event(now, &clocks).filter(|&t| t > now);
            let quiet_until = systick.map_or(until, |t| t.min(until));
            let reached = with_bus(&mut self.uc, |bus, mem, now| {
                bus.skip(now, quiet_until, mem)
            });
            let st = self.uc.get_data_mut();
            if reached > now {
                st.slice_start = reached;
                st.slice_instructions = 0;
                st.sync_lines();
                if st.event || st.nvic.to_take(masks).is_some() {
                    return Ok(());
                }
            }
            st.sleeps += 1;
            let now = st.now();
            let bus = st.bus.as_ref().expect("the bus is present");
            let clocks = bus.clocks();
            let next = [bus.next_event(now), st.nvic.next_event(now, &clocks)]
                .into_iter()
                .flatten()
                .filter(|&t| t > now)
                .fold(until, Time::min);
            st.slice_start = next;
            st.slice_instructions = 0;
            if next >= until {
                return Ok(());
            }
            self.sync()?;
            let st = self.uc.get_data();
            if st.event || st.nvic.to_take(masks).is_some() || st.nvic.reset_requested() {
                return Ok(());
            }
            if self.take_reset() {
                return self.reset();
            }
        }
    }

    /// Run one slice of instructions: up to the next peripheral event (at most
    /// [`MAX_SLICE`]), a `wfe` that sleeps, or an exception return.
    fn slice(&mut self, until: Time) -> Result<(), CpuError> {
        let st = self.uc.get_data_mut();
        st.slices += 1;
        let now = st.now();
        let bus = st.bus.as_ref().expect("the bus is present");
        let clocks = bus.clocks();
        let next = [bus.next_event(now), st.nvic.next_event(now, &clocks)]
            .into_iter()
            .flatten()
            .fold(until, Time::min);
        let left = super::Clocks::ticks(next.saturating_sub(now), st.sysclk_hz);
        st.slice_start = now;
        st.slice_instructions = 0;
        // An interrupt pending here is masked (the core would have taken it): short slices
        // until the masks open.
        let longest = if st.nvic.highest_pending().is_some() {
            MASKED_SLICE
        } else {
            MAX_SLICE
        };
        st.slice_limit = left.clamp(1, longest);
        st.recheck = false;
        let pc = self.reg(RegisterARM::PC);
        match self.uc.emu_start(u64::from(pc | 1), 0xFFFF_FFFF, 0, 0) {
            Ok(()) => Ok(()),
            Err(err) => {
                let pc = self.reg(RegisterARM::PC);
                if pc >= EXC_RETURN_MIN {
                    return self.exit(pc | 1);
                }
                // unicorn takes an M-profile `wfe` as an invalid instruction: one that runs
                // (its hook found the event register set) has completed.
                if err == uc_error::INSN_INVALID {
                    let hw = |at: u32| {
                        let mut b = [0u8; 2];
                        self.uc
                            .mem_read(u64::from(at), &mut b)
                            .ok()
                            .map(|()| u16::from_le_bytes(b))
                    };
                    if hw(pc) == Some(0xBF20) {
                        return self
                            .uc
                            .reg_write(RegisterARM::PC, u64::from(pc + 2))
                            .map_err(|err| CpuError::Core { pc, err });
                    }
                    if hw(pc.wrapping_sub(2)) == Some(0xBF20) {
                        return Ok(());
                    }
                }
                Err(CpuError::Core { pc, err })
            }
        }
    }

    /// Take exception `e` (ARMv7-M B1.5.6, PushStack and ExceptionTaken).
    fn enter(&mut self, e: u16) -> Result<(), CpuError> {
        let control = self.reg(RegisterARM::CONTROL);
        let st = self.uc.get_data();
        let thread = st.nvic.current() == 0;
        let fpca = control & 0b100 != 0;
        let psp = thread && control & 0b010 != 0;
        let sp = if psp {
            self.reg(RegisterARM::PSP)
        } else {
            self.reg(RegisterARM::MSP)
        };
        let frame_bytes = if fpca { 0x68 } else { 0x20 };
        let aligned = (sp - frame_bytes) & !7;
        let realigned = (sp - frame_bytes) & 4 != 0;
        let pc = self.reg(RegisterARM::PC);
        let xpsr = self.reg(RegisterARM::XPSR);
        let mut words = vec![
            self.reg(RegisterARM::R0),
            self.reg(RegisterARM::R1),
            self.reg(RegisterARM::R2),
            self.reg(RegisterARM::R3),
            self.reg(RegisterARM::R12),
            self.reg(RegisterARM::LR),
            pc & !1,
            (xpsr & !(1 << 9)) | u32::from(realigned) << 9 | 1 << 24,
        ];
        if fpca {
            for i in 0..16 {
                words.push(self.reg(s_reg(i)));
            }
            words.push(self.reg(RegisterARM::FPSCR));
            words.push(0);
        }
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        self.write_bytes(aligned, &bytes)?;
        let vtor = self.uc.get_data().nvic.vtor();
        let table = if vtor == 0 { FLASH_BASE } else { vtor };
        let handler = self.read_u32(table + 4 * u32::from(e))?;
        let exc_return: u32 = match (thread, psp, fpca) {
            (false, _, false) => 0xFFFF_FFF1,
            (false, _, true) => 0xFFFF_FFE1,
            (true, false, false) => 0xFFFF_FFF9,
            (true, false, true) => 0xFFFF_FFE9,
            (true, true, false) => 0xFFFF_FFFD,
            (true, true, true) => 0xFFFF_FFED,
        };
        let err = |err| CpuError::Core { pc, err };
        let uc = &mut self.uc;
        if psp {
            uc.reg_write(RegisterARM::PSP, u64::from(aligned))
                .map_err(err)?;
        } else {
            uc.reg_write(RegisterARM::MSP, u64::from(aligned))
                .map_err(err)?;
        }
        if fpca {
            uc.get_data_mut().nvic.set_fpcar(aligned + 0x20);
        }
        // Handler mode: the main stack, no FP context yet.
        uc.reg_write(RegisterARM::CONTROL, u64::from(control & !0b110))
            .map_err(err)?;
        uc.reg_write(RegisterARM::SP, u64::from(aligned))
            .map_err(err)?;
        uc.reg_write(RegisterARM::LR, u64::from(exc_return))
            .map_err(err)?;
        uc.reg_write(RegisterARM::XPSR, 1 << 24).map_err(err)?;
        uc.reg_write(RegisterARM::PC, u64::from(handler & !1))
            .map_err(err)?;
        uc.get_data_mut().nvic.acknowledge(e);
        Ok(())
    }

    /// Return from the innermost exception with `exc_return` (ARMv7-M B1.5.8, ExceptionReturn
    /// and PopStack).
    fn exit(&mut self, exc_return: u32) -> Result<(), CpuError> {
        let active = self.uc.get_data().nvic.current();
        let bad = |core: &Core| CpuError::BadReturn {
            exc_return,
            active,
            pc: core.reg(RegisterARM::PC),
        };
        let to_thread = exc_return & 0b1000 != 0;
        let psp = exc_return & 0b0100 != 0;
        let basic = exc_return & 0x10 != 0;
        let base_ok = matches!(exc_return | 0x10, 0xFFFF_FFF1 | 0xFFFF_FFF9 | 0xFFFF_FFFD);
        if active == 0 || !base_ok || (to_thread != self.uc.get_data().nvic.returns_to_base()) {
            return Err(bad(self));
        }
        // The handler may have lowered its line just before returning.
        self.uc.get_data_mut().sync_lines();
        if !self.uc.get_data_mut().nvic.complete(active) {
            return Err(bad(self));
        }
        let sp = if psp {
            self.reg(RegisterARM::PSP)
        } else {
            self.reg(RegisterARM::MSP)
        };
        let n = if basic { 8 } else { 26 };
        let mut bytes = vec![0u8; 4 * n];
        self.read_bytes(sp, &mut bytes)?;
        let w: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let err = |err| CpuError::Core { pc: w[6], err };
        let uc = &mut self.uc;
        for (r, v) in [
            (RegisterARM::R0, w[0]),
            (RegisterARM::R1, w[1]),
            (RegisterARM::R2, w[2]),
            (RegisterARM::R3, w[3]),
            (RegisterARM::R12, w[4]),
            (RegisterARM::LR, w[5]),
        ] {
            uc.reg_write(r, u64::from(v)).map_err(err)?;
        }
        if !basic {
            for i in 0..16 {
                uc.reg_write(s_reg(i), u64::from(w[8 + i])).map_err(err)?;
            }
            uc.reg_write(RegisterARM::FPSCR, u64::from(w[24]))
                .map_err(err)?;
        }
        let realigned = w[7] & (1 << 9) != 0;
        let new_sp = sp + 4 * n as u32 + if realigned { 4 } else { 0 };
        let control = self.reg(RegisterARM::CONTROL);
        let control = (control & !0b110)
            | if to_thread && psp { 0b010 } else { 0 }
            | if basic { 0 } else { 0b100 };
        let uc = &mut self.uc;
        uc.reg_write(RegisterARM::CONTROL, u64::from(control))
            .map_err(err)?;
        if psp {
            uc.reg_write(RegisterARM::PSP, u64::from(new_sp))
                .map_err(err)?;
        } else {
            uc.reg_write(RegisterARM::MSP, u64::from(new_sp))
                .map_err(err)?;
        }
        uc.reg_write(RegisterARM::SP, u64::from(new_sp))
            .map_err(err)?;
        uc.reg_write(RegisterARM::XPSR, u64::from(w[7] & !(1 << 9)))
            .map_err(err)?;
        uc.reg_write(RegisterARM::PC, u64::from(w[6] & !1))
            .map_err(err)?;
        Ok(())
    }
}

/// The chip's memories as the core reaches them (SRAM, the flash and its alias): a probe's
/// reads and writes (the RTT buffers), which take no time.
impl Memory for Core {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> bool {
        self.read_bytes(addr, buf).is_ok()
    }

    fn write(&mut self, addr: u32, bytes: &[u8]) -> bool {
        self.write_bytes(addr, bytes).is_ok()
    }
}

/// The single-precision register `Si`.
fn s_reg(i: usize) -> RegisterARM {
    const S: [RegisterARM; 16] = [
        RegisterARM::S0,
        RegisterARM::S1,
        RegisterARM::S2,
        RegisterARM::S3,
        RegisterARM::S4,
        RegisterARM::S5,
        RegisterARM::S6,
        RegisterARM::S7,
        RegisterARM::S8,
        RegisterARM::S9,
        RegisterARM::S10,
        RegisterARM::S11,
        RegisterARM::S12,
        RegisterARM::S13,
        RegisterARM::S14,
        RegisterARM::S15,
    ];
    S[i]
}

/// Thumb instructions in a block of code: a halfword whose top five bits are 0b11101, 0b11110
/// or 0b11111 starts a 32-bit instruction.
pub fn thumb_instructions(code: &[u8]) -> u32 {
    let mut i = 0;
    let mut n = 0;
    while i + 1 < code.len() {
        let hw = u16::from_le_bytes([code[i], code[i + 1]]);
        i += if hw >> 11 >= 0b11101 { 4 } else { 2 };
        n += 1;
    }
    n.max(1)
}

/// Map the System Control Space and the peripheral windows as MMIO: the SCS to the NVIC,
/// the rest to the bus.
fn map_windows(uc: &mut Unicorn<'static, State>) -> Result<(), uc_error> {
    for (base, len) in WINDOWS {
        uc.mmio_map(
            u64::from(base),
            u64::from(len),
            Some(move |uc: &mut Unicorn<'_, State>, off: u64, size: usize| {
                let addr = base + off as u32;
                let size = Size::of(size as u32).unwrap_or(Size::Word);
                if (SCS_BASE..SCS_BASE + 0x1000).contains(&addr) {
                    let now = uc.get_data().now();
                    let st = uc.get_data_mut();
                    let clocks = st.bus.as_ref().expect("the bus is present").clocks();
                    st.nvic.advance(now, &clocks);
                    return u64::from(st.nvic.read(addr - SCS_BASE, size));
                }
                let r = with_bus(uc, |bus, mem, now| bus.read(addr, size, now, mem));
                u64::from(r.unwrap_or_else(|| {
                    uc.get_data_mut()
                        .faults
                        .push(BusFault { addr, write: false });
                    0
                }))
            }),
            Some(
                move |uc: &mut Unicorn<'_, State>, off: u64, size: usize, value: u64| {
                    let addr = base + off as u32;
                    let size = Size::of(size as u32).unwrap_or(Size::Word);
                    if (SCS_BASE..SCS_BASE + 0x1000).contains(&addr) {
                        let st = uc.get_data_mut();
                        st.nvic.write(addr - SCS_BASE, size, value as u32);
                        st.recheck = true;
                        return;
                    }
                    let ok = with_bus(uc, |bus, mem, now| {
                        bus.write(addr, size, value as u32, now, mem)
                    });
                    // A write may raise an interrupt line or unmask one: the slice ends
                    // at the block's end if an interrupt is now to be taken.
                    let due = interrupt_due(uc, addr);
                    let st = uc.get_data_mut();
                    st.recheck |= due;
                    if !ok {
                        st.faults.push(BusFault { addr, write: true });
                    }
                },
            ),
        )?;
    }
    Ok(())
}

/// Lets a store to SRAM take unicorn's fast path (the default cycle runs ≈ 1.6× faster).
///
/// unicorn's own TLB takes page permissions from the M-profile default memory map, in which
/// SRAM is executable, and a store to an executable page takes a slow path that looks for
/// translated code there, on every store: unicorn never marks such a page clean. With the
/// virtual TLB the harness gives the permissions ([`page_perms`]): SRAM is not executable
/// (the ELF runs from flash), and the mapped regions' own permissions still apply.
///
/// unicorn's fill restores the state of the instruction that missed, IT bits included, which
/// translated code otherwise writes only when they are non-zero at a block's end: left there
/// they make the next block decode as if inside an IT block. The hook clears them after a
/// data access's fill (code inside an IT block at a block's end writes them itself); a fetch's
/// fill restores nothing and is left alone.
fn fast_sram_stores(uc: &mut Unicorn<'static, State>) -> Result<(), uc_error> {
    uc.ctl_set_tlb_type(TlbType::VIRTUAL)?;
    uc.add_tlb_hook(1, 0, |uc, addr, kind| {
        if kind != MemType::FETCH
            && let Ok(xpsr) = uc.reg_read(RegisterARM::XPSR)
            && xpsr & XPSR_IT != 0
        {
            let _ = uc.reg_write(RegisterARM::EAPSR_G, xpsr & !XPSR_IT);
        }
        Some(TlbEntry {
            paddr: addr,
            perms: page_perms(addr as u32),
        })
    })?;
    Ok(())
}

/// The IT bits of xPSR (ICI/IT: bits 26:25 and 15:10).
const XPSR_IT: u64 = 0x0600_FC00;

/// A page's permissions: the ARMv7-M default memory map (B3.1), with two changes. SRAM is
/// execute-never. The system space is fetchable: a fetch there is a branch to EXC_RETURN
/// (which ends the slice as an unmapped fetch, taken by [`Core::slice`] as the exception
/// return) or unicorn's look at the emulation's end address, which must not fault.
fn page_perms(addr: u32) -> Prot {
    let sram = SRAM_BASE..SRAM_BASE + SRAM_BYTES;
    match addr {
        _ if sram.contains(&addr) => Prot::READ | Prot::WRITE,
        0x0000_0000..=0x1FFF_FFFF | 0x6000_0000..=0x9FFF_FFFF | 0xE000_0000.. => Prot::ALL,
        // The SRAM region beyond the chip's SRAM, peripherals and devices.
        _ => Prot::READ | Prot::WRITE,
    }
}
