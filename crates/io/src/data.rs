//! Where the real recordings live: `$NAVFUSE_DATA`, else `../shared/data`
//! relative to the workspace root.
//!
//! Real-data tests are `#[ignore]`d in the default test run and are run by
//! `cargo test --release --workspace -- --ignored` (see README). They call
//! [`require`], which panics with a clear message when the data is missing:
//! a real-data check never skips silently.

use std::path::{Path, PathBuf};

/// The data root: `$NAVFUSE_DATA` if set, else `<workspace>/../shared/data`.
pub fn data_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("NAVFUSE_DATA") {
        return PathBuf::from(d);
    }
    // crates/io → workspace root → its parent; shown resolved when it exists.
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    p.canonicalize().unwrap_or(p)
}

/// Path of `rel` under the data root; panics naming the path and the
/// `NAVFUSE_DATA` variable when it does not exist.
pub fn require(rel: &str) -> PathBuf {
    let p = data_dir().join(rel);
    if !p.exists() {
        panic!(
            "real data missing: {} (set NAVFUSE_DATA to the folder holding drive_0708/, gnss/, static_vn310/)",
            p.display()
        );
    }
    p
}

#[cfg(test)]
mod tests {
    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn shared_data_is_present() {
        let p = super::require("drive_0708/gnss_1934_sf.pos");
        assert!(p.metadata().unwrap().len() > 100_000);
    }
}
