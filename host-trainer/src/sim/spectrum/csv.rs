//! The spectra CSV (the plain format): `t_s,channel,` then one column per grid
//! wavelength named in nm with 3 decimals, one row per sample and channel, linear counts.

use std::io::Write;

use super::frames::{row_rng, wavelengths_at, FrameSimulator};
use crate::data::Dataset;

/// Write the frames of every row of `data` (noise seeded by `seed`, the same frames
/// [`super::chain::peaks_from_spectra`] detects with that seed) to `w`: the header
/// `t_s,channel,1510.000,…`, then for each row and channel (1-based) its time \[s\] and its
/// counts. The channels' gratings are [`FrameSimulator::gratings_of`].
pub fn write_spectra_csv(
    w: &mut impl Write,
    data: &Dataset,
    frames: &FrameSimulator,
    seed: u64,
) -> std::io::Result<()> {
    write!(w, "t_s,channel")?;
    for l in frames.wavelengths_nm() {
        write!(w, ",{l:.3}")?;
    }
    writeln!(w)?;
    let (mut scratch, mut counts) = (Vec::new(), Vec::new());
    for (i, t) in data.t_s.iter().enumerate() {
        let wl = wavelengths_at(data, i);
        let mut rng = row_rng(seed, i);
        for c in 0..frames.channels() {
            frames.frame(c, &wl, &mut rng, &mut scratch, &mut counts);
            write!(w, "{t},{}", c + 1)?;
            for v in &counts {
                write!(w, ",{v}")?;
            }
            writeln!(w)?;
        }
    }
    Ok(())
}
