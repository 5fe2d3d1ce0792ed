//! The simulated board's flash: where `save` and `load` are carried out for every simulator
//! command — a record kept in memory for the run (`host-sim run`, `paper`, the tests) or the
//! settings file of `host-sim console`.

use std::path::{Path, PathBuf};

use thermorph::supervisor::report::Reply;
use thermorph::supervisor::store::{StoreOutcome, StoreRequest};
use thermorph::units::Millis;

use thermorph::app::Controller;

use crate::rig::RigError;

/// The settings file: the record's bytes, written whole (a temporary file renamed over it).
#[derive(Clone, Debug)]
pub struct SettingsFile {
    path: PathBuf,
}

impl SettingsFile {
    /// The file at `path`.
    pub fn new(path: PathBuf) -> Self {
        SettingsFile { path }
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Read the stored record: `Ok(None)` when there is no file.
    pub fn read(&self) -> Result<Option<Vec<u8>>, RigError> {
        match std::fs::read(&self.path) {
            Ok(b) => Ok(Some(b)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(err) => Err(RigError::SettingsFile {
                path: self.path.clone(),
                err,
            }),
        }
    }

    /// Write a record.
    pub fn write(&self, record: &[u8]) -> Result<(), RigError> {
        if let Some(dir) = self.path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|err| RigError::SettingsFile {
                path: dir.to_path_buf(),
                err,
            })?;
        }
        let tmp = self.path.with_extension("tmp");
        std::fs::write(&tmp, record)
            .and_then(|()| std::fs::rename(&tmp, &self.path))
            .map_err(|err| RigError::SettingsFile {
                path: self.path.clone(),
                err,
            })
    }
}

/// Where the simulated board keeps its settings record.
#[derive(Clone, Debug)]
pub enum SimFlash {
    /// In memory, for the run: empty at the start.
    Memory(Option<Vec<u8>>),
    /// In a file that outlives the process.
    File(SettingsFile),
}

impl SimFlash {
    /// Carry out `req` for `control` at `now` (the simulated flash is instant); return the
    /// command's reply. A file that cannot be read or written is a failed operation (the
    /// reason on standard error) and loses nothing.
    pub fn carry_out(
        &mut self,
        req: &StoreRequest,
        control: &mut Controller,
        now: Millis,
    ) -> Reply {
        // A file's record, read for `load`, lives here while the outcome borrows it.
        let read: Option<Vec<u8>>;
        let outcome = match (self, req) {
            (SimFlash::Memory(kept), StoreRequest::Save(record)) => {
                *kept = Some(record.to_vec());
                StoreOutcome::Saved
            }
            (SimFlash::Memory(kept), StoreRequest::Load) => StoreOutcome::Loaded(kept.as_deref()),
            (SimFlash::File(f), StoreRequest::Save(record)) => match f.write(record) {
                Ok(()) => StoreOutcome::Saved,
                Err(e) => {
                    eprintln!("host-sim: save: {e}");
                    StoreOutcome::Failed("cannot write the settings file")
                }
            },
            (SimFlash::File(f), StoreRequest::Load) => match f.read() {
                Ok(b) => {
                    read = b;
                    StoreOutcome::Loaded(read.as_deref())
                }
                Err(e) => {
                    eprintln!("host-sim: load: {e}");
                    StoreOutcome::Failed("cannot read the settings file")
                }
            },
        };
        control.finish_store(now, outcome)
    }
}
