//! `heli link keygen`: a new signing key for the vehicle and the ground (`heli_link::setup`).

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;

/// `heli link keygen --out FILE`: a new random key, written readable by its owner only.
pub fn keygen(out: &Path, force: bool) -> Result<ExitCode> {
    heli_link::setup::keygen(out, force)?;
    println!(
        "wrote {}: give the same file to the vehicle (heli vehicle --key) and the ground (heli ground --key)",
        out.display()
    );
    Ok(ExitCode::SUCCESS)
}
