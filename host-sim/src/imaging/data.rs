//! Location of the public sensor dumps in `../shared/data/mlx90640/` (never copied here).

use std::path::PathBuf;

/// Environment variable that overrides the sensor-dump folder.
pub const DATA_DIR_ENV: &str = "THERMORPH_DATA_DIR";
/// Environment variable that turns a missing data folder from a skip into a failure (CI).
pub const REQUIRE_DATA_ENV: &str = "THERMORPH_REQUIRE_DATA";

/// Return the MLX90640 dump folder: `$THERMORPH_DATA_DIR`, else `../shared/data/mlx90640`
/// beside the workspace.
pub fn mlx90640_dir() -> PathBuf {
    match std::env::var_os(DATA_DIR_ENV) {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../shared/data/mlx90640"
        )),
    }
}

/// Return the dump folder if it exists. Where it is missing, print a skip notice and return
/// `None` — or panic if `$THERMORPH_REQUIRE_DATA` is set, so CI cannot skip silently.
pub fn require_mlx90640_dir(test: &str) -> Option<PathBuf> {
    let dir = mlx90640_dir();
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os(REQUIRE_DATA_ENV).is_some() {
        panic!(
            "{test}: sensor data folder {} is missing and {REQUIRE_DATA_ENV} is set",
            dir.display()
        );
    }
    eprintln!(
        "SKIPPED {test}: sensor data folder {} is missing",
        dir.display()
    );
    None
}
