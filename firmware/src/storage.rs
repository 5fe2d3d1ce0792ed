//! Settings in flash: the settings record ([`Record`]) kept by sequential-storage's map in two or
//! more erase pages of a NOR flash, written only on `save`.
//!
//! This module owns the flash side of `save` and `load`: [`FlashStore`] over any
//! `embedded_storage_async` [`NorFlash`] (the board gives it the F446's flash, the tests an
//! in-memory NOR model). sequential-storage appends each saved record under one key, erases a
//! page only when the pages are full (wear levelling), checks every item with its own CRC and
//! survives a reset in the middle of a write (the last complete record is read back). The
//! record's own version, layout id and CRC ([`Settings::decode`]) then decide whether its
//! values are used.
//!
//! On the board: `FlashStore::new(flash, range)` once at start; [`FlashStore::boot_settings`]
//! for `Supervisor::new`; for a step whose [`Decision::store`](crate::supervisor::Decision) is
//! set, [`FlashStore::carry_out`] gives the command's reply.

use core::fmt::Write;
use core::ops::Range;

use embedded_storage_async::nor_flash::NorFlash;
use sequential_storage::Error;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

use crate::settings::{RECORD_LEN, Record, Settings};
use crate::supervisor::Supervisor;
use crate::supervisor::report::Reply;
use crate::supervisor::store::{StoreOutcome, StoreRequest, settings_at_boot};
use crate::units::Millis;

/// The map key of the settings record.
pub const SETTINGS_KEY: u8 = 1;

/// Working buffer: the key, the record and sequential-storage's item header, rounded up to any
/// flash word up to 32 bytes.
const BUFFER_LEN: usize = (1 + RECORD_LEN + 32).div_ceil(32) * 32;

type Map<'a, F> = MapStorage<u8, &'a mut F, Cache<Uncached, Uncached, Uncached, u8>>;

/// The settings record in a range of a NOR flash.
pub struct FlashStore<F: NorFlash> {
    flash: F,
    range: Range<u32>,
    buf: [u8; BUFFER_LEN],
}

/// Why a flash range cannot hold the settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RangeError {
    /// The range must start and end on erase-page boundaries and span at least two pages.
    NotTwoWholePages,
}

/// Why the flash could not give or take the settings record. [`fmt::Display`](core::fmt::Display)
/// gives the message the console and the boot warning show; it is written by hand, as
/// `thiserror` is not used in this `no_std` crate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum StorageError {
    /// The flash driver reported an error.
    Flash,
    /// No room left in the range (sequential-storage could not free a page).
    Full,
    /// sequential-storage found its own structures corrupted.
    Corrupted,
    /// The record does not fit the working buffer or a page.
    DoesNotFit,
    /// Any other sequential-storage error.
    Other,
    /// The range is not whole erase pages (at least two).
    BadRange,
    /// The record read back after a write differs from the one written.
    ReadBackDiffers,
    /// The range holds data but no whole record (at boot).
    NoWholeRecord,
}

impl StorageError {
    /// Return the message (what [`fmt::Display`](core::fmt::Display) writes).
    pub fn message(self) -> &'static str {
        match self {
            Self::Flash => "flash error",
            Self::Full => "flash full",
            Self::Corrupted => "flash corrupted",
            Self::DoesNotFit => "record does not fit",
            Self::Other => "flash storage error",
            Self::BadRange => "bad flash range",
            Self::ReadBackDiffers => "read back differs",
            Self::NoWholeRecord => "no whole record",
        }
    }
}

impl core::fmt::Display for StorageError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

fn why<E>(e: &Error<E>) -> StorageError {
    match e {
        Error::Storage { .. } => StorageError::Flash,
        Error::FullStorage => StorageError::Full,
        Error::Corrupted { .. } => StorageError::Corrupted,
        Error::BufferTooSmall(_) | Error::BufferTooBig => StorageError::DoesNotFit,
        _ => StorageError::Other,
    }
}

impl<F: NorFlash> FlashStore<F> {
    /// Keep the settings in `range` of `flash` (byte offsets; whole erase pages, at least two).
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, RangeError> {
        MapConfig::<F>::try_new(range.clone()).map_err(|_| RangeError::NotTwoWholePages)?;
        Ok(FlashStore {
            flash,
            range,
            buf: [0; BUFFER_LEN],
        })
    }

    fn map<'a>(flash: &'a mut F, range: &Range<u32>) -> Result<Map<'a, F>, StorageError> {
        let config = MapConfig::try_new(range.clone()).map_err(|_| StorageError::BadRange)?;
        Ok(MapStorage::new(flash, config, Cache::new_uncached()))
    }

    /// Read the stored record's bytes (`None`: nothing stored, or only a damaged record, which
    /// sequential-storage's item CRC skips).
    pub async fn read(&mut self) -> Result<Option<&[u8]>, StorageError> {
        Self::map(&mut self.flash, &self.range)?
            .fetch_item::<&[u8]>(&mut self.buf, &SETTINGS_KEY)
            .await
            .map_err(|e| why(&e))
    }

    /// Whether the whole range is erased (nothing was ever stored).
    async fn blank(&mut self) -> Result<bool, StorageError> {
        let mut at = self.range.start;
        let mut chunk = [0u8; 64];
        while at < self.range.end {
            let n = (self.range.end - at).min(chunk.len() as u32);
            let c = &mut chunk[..n as usize];
            self.flash
                .read(at, c)
                .await
                .map_err(|_| StorageError::Flash)?;
            if c.iter().any(|&b| b != 0xFF) {
                return Ok(false);
            }
            at += n;
        }
        Ok(true)
    }

    /// Store `record`, then read it back and compare.
    pub async fn write(&mut self, record: &Record) -> Result<(), StorageError> {
        Self::map(&mut self.flash, &self.range)?
            .store_item(&mut self.buf, &SETTINGS_KEY, &&record[..])
            .await
            .map_err(|e| why(&e))?;
        match self.read().await? {
            Some(b) if b == &record[..] => Ok(()),
            _ => Err(StorageError::ReadBackDiffers),
        }
    }

    /// The settings to start with (see [`settings_at_boot`]); an unreadable flash, or one that
    /// holds data but no whole record, also gives the defaults with a `# warning` line.
    pub async fn boot_settings(&mut self, console: &mut impl Write) -> Settings {
        let e = match self.read().await {
            Ok(Some(stored)) => return settings_at_boot(Some(stored), console),
            Ok(None) => match self.blank().await {
                Ok(true) => return Settings::DEFAULT,
                Ok(false) => StorageError::NoWholeRecord,
                Err(e) => e,
            },
            Err(e) => e,
        };
        let _ = write!(
            console,
            "# warning: stored settings not used ({e}); defaults in use\r\n"
        );
        Settings::DEFAULT
    }

    /// Carry out a step's [`StoreRequest`] (the caller has applied that step's outputs, heater
    /// and springs off); return the command's reply. `now` tells the time the operation ended.
    pub async fn carry_out(
        &mut self,
        req: &StoreRequest,
        supervisor: &mut Supervisor,
        now: impl Fn() -> Millis,
    ) -> Reply {
        match req {
            StoreRequest::Save(record) => match self.write(record).await {
                Ok(()) => supervisor.finish_store(now(), StoreOutcome::Saved),
                Err(e) => supervisor.finish_store(now(), StoreOutcome::Failed(e.message())),
            },
            StoreRequest::Load => match self.read().await {
                Ok(b) => supervisor.finish_store(now(), StoreOutcome::Loaded(b)),
                Err(e) => supervisor.finish_store(now(), StoreOutcome::Failed(e.message())),
            },
        }
    }

    /// Give the flash back.
    pub fn release(self) -> F {
        self.flash
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::parse;
    use crate::units::Millis;
    use embassy_futures::block_on;
    use embedded_storage_async::nor_flash::{
        ErrorType, NorFlashError, NorFlashErrorKind, ReadNorFlash,
    };
    use std::string::String;
    use std::vec;
    use std::vec::Vec;

    /// A NOR flash in memory with the F446's programming rules: erased bytes read 0xFF, a write
    /// is word-aligned and may only program erased words (no second write without an erase),
    /// and a power cut can be scheduled after a number of word writes.
    struct Nor {
        mem: Vec<u8>,
        erases: usize,
        writes_left: Option<usize>,
    }

    #[derive(Debug)]
    struct NorError(NorFlashErrorKind);

    impl NorFlashError for NorError {
        fn kind(&self) -> NorFlashErrorKind {
            self.0
        }
    }

    impl Nor {
        const PAGE: usize = 16 * 1024;
        fn new(pages: usize) -> Self {
            Nor {
                mem: vec![0xFF; pages * Self::PAGE],
                erases: 0,
                writes_left: None,
            }
        }
    }

    impl ErrorType for Nor {
        type Error = NorError;
    }

    impl ReadNorFlash for Nor {
        const READ_SIZE: usize = 1;
        async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), NorError> {
            let at = offset as usize;
            let src = self
                .mem
                .get(at..at + bytes.len())
                .ok_or(NorError(NorFlashErrorKind::OutOfBounds))?;
            bytes.copy_from_slice(src);
            Ok(())
        }
        fn capacity(&self) -> usize {
            self.mem.len()
        }
    }

    impl NorFlash for Nor {
        const WRITE_SIZE: usize = 4;
        const ERASE_SIZE: usize = Self::PAGE;
        async fn erase(&mut self, from: u32, to: u32) -> Result<(), NorError> {
            let (a, b) = (from as usize, to as usize);
            if a % Self::PAGE != 0 || b % Self::PAGE != 0 || b > self.mem.len() {
                return Err(NorError(NorFlashErrorKind::NotAligned));
            }
            self.mem[a..b].fill(0xFF);
            self.erases += (b - a) / Self::PAGE;
            Ok(())
        }
        async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), NorError> {
            let at = offset as usize;
            if !at.is_multiple_of(4) || !bytes.len().is_multiple_of(4) {
                return Err(NorError(NorFlashErrorKind::NotAligned));
            }
            for (i, w) in bytes.chunks(4).enumerate() {
                if let Some(n) = &mut self.writes_left {
                    if *n == 0 {
                        return Err(NorError(NorFlashErrorKind::Other));
                    }
                    *n -= 1;
                }
                let dst = &mut self.mem[at + 4 * i..at + 4 * i + 4];
                if dst.iter().any(|&b| b != 0xFF) {
                    return Err(NorError(NorFlashErrorKind::Other));
                }
                dst.copy_from_slice(w);
            }
            Ok(())
        }
    }

    fn settings_with_hot(k: f32) -> Settings {
        let mut s = Settings::DEFAULT;
        s.set("hot_k", k).unwrap();
        s
    }

    #[test]
    fn the_range_must_be_two_whole_pages() {
        let page = Nor::PAGE as u32;
        assert!(FlashStore::new(Nor::new(2), 0..page).is_err());
        assert!(FlashStore::new(Nor::new(2), 4..2 * page).is_err());
        assert!(FlashStore::new(Nor::new(2), 0..2 * page).is_ok());
    }

    #[test]
    fn empty_flash_gives_the_defaults_without_a_warning() {
        let mut store = FlashStore::new(Nor::new(2), 0..2 * Nor::PAGE as u32).unwrap();
        let mut out = String::new();
        assert_eq!(block_on(store.boot_settings(&mut out)), Settings::DEFAULT);
        assert_eq!(out, "");
    }

    #[test]
    fn a_thousand_saves_wear_the_pages_evenly_and_the_last_is_read() {
        let range = 0..2 * Nor::PAGE as u32;
        let mut store = FlashStore::new(Nor::new(2), range.clone()).unwrap();
        for i in 0..1000 {
            let s = settings_with_hot(338.0 + (i % 30) as f32);
            block_on(store.write(&s.encode())).unwrap();
        }
        let nor = store.release();
        // 1000 records of a few hundred bytes and their headers in 16 KiB pages: about 11 page erases.
        assert!((5..=30).contains(&nor.erases), "{} erases", nor.erases);
        let mut store = FlashStore::new(nor, range).unwrap();
        let mut out = String::new();
        let s = block_on(store.boot_settings(&mut out));
        assert_eq!(s.hot_k, 338.0 + (999 % 30) as f32);
        assert_eq!(out, "");
    }

    #[test]
    fn a_reset_in_the_middle_of_a_save_keeps_one_whole_record() {
        let range = 0..2 * Nor::PAGE as u32;
        let (old, new) = (settings_with_hot(350.0), settings_with_hot(360.0));
        // Enough saves first that the cut also falls on a page change for some n.
        let mut base = FlashStore::new(Nor::new(2), range.clone()).unwrap();
        for _ in 0..90 {
            block_on(base.write(&old.encode())).unwrap();
        }
        let base = base.release();
        let mut outcomes = [0usize; 2];
        for n in 0..120 {
            let nor = Nor {
                mem: base.mem.clone(),
                erases: 0,
                writes_left: Some(n),
            };
            let mut store = FlashStore::new(nor, range.clone()).unwrap();
            let cut = block_on(store.write(&new.encode())).is_err();
            let mut nor = store.release();
            nor.writes_left = None;
            let mut store = FlashStore::new(nor, range.clone()).unwrap();
            let mut out = String::new();
            let s = block_on(store.boot_settings(&mut out));
            assert_eq!(out, "", "cut after {n} words");
            if s == new {
                outcomes[1] += 1;
            } else {
                assert_eq!(s, old, "cut after {n} words");
                assert!(cut);
                outcomes[0] += 1;
            }
        }
        assert!(outcomes[0] > 0 && outcomes[1] > 0, "{outcomes:?}");
    }

    #[test]
    fn a_damaged_record_falls_back_to_the_defaults_with_a_warning() {
        let range = 0..2 * Nor::PAGE as u32;
        let mut store = FlashStore::new(Nor::new(2), range.clone()).unwrap();
        block_on(store.write(&settings_with_hot(360.0).encode())).unwrap();
        let mut nor = store.release();
        // Clear one bit inside the stored record (NOR can always program a 1 to 0).
        let at = nor
            .mem
            .windows(4)
            .position(|w| w == b"TMRS")
            .expect("the record is in flash");
        // The top byte of hot_k (360 K = 0x43B4_0000): 0x43 → 0x42.
        assert_eq!(nor.mem[at + 19], 0x43);
        nor.mem[at + 19] &= 0xFE;
        let mut store = FlashStore::new(nor, range).unwrap();
        let mut out = String::new();
        assert_eq!(block_on(store.boot_settings(&mut out)), Settings::DEFAULT);
        assert!(out.starts_with("# warning: "), "{out:?}");
        assert!(out.ends_with("; defaults in use\r\n"), "{out:?}");
    }

    #[test]
    fn save_and_load_commands_through_the_flash() {
        let mut store = FlashStore::new(Nor::new(2), 0..2 * Nor::PAGE as u32).unwrap();
        let mut sup = Supervisor::new(Millis(0), Settings::DEFAULT);
        let line = |sup: &mut Supervisor, store: &mut FlashStore<Nor>, l: &str| {
            let d = sup.step(Millis(1), None, Some(parse(l).unwrap()));
            match (d.reply, d.store) {
                (Some(r), None) => r,
                (None, Some(req)) => block_on(store.carry_out(&req, sup, || Millis(20))),
                other => panic!("{other:?}"),
            }
        };
        assert!(line(&mut sup, &mut store, "set hot_k 361").is_ok());
        let r = line(&mut sup, &mut store, "save");
        assert!(r.as_str().starts_with("ok saved"), "{r:?}");
        line(&mut sup, &mut store, "defaults");
        assert_eq!(sup.settings().hot_k, 358.0);
        let r = line(&mut sup, &mut store, "load");
        assert!(r.as_str().starts_with("ok loaded"), "{r:?}");
        assert_eq!(sup.settings().hot_k, 361.0);
    }
}
