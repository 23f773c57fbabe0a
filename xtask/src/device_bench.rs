//! Device measurements (placeholder while the firmware lands).
use std::path::Path;

use anyhow::Result;

/// Footprint of the firmware.
pub fn size(_root: &Path) -> Result<()> {
    Ok(())
}

/// Device bench.
pub fn run(_root: &Path) -> Result<()> {
    Ok(())
}
