//! Frames to per-grating peaks: one [`PeakDetector`] per channel ([`ChannelDetector`]), built
//! once (from the map's windows, or from the peaks discovered in the channel's first spectrum)
//! and reused for every frame; the results kept per grating and frame.

use fbg_shared::spectrum::{DetectorConfig, Peak, PeakDetector, PeakFlags, Spectrum, Window};

use super::super::mapping;
use super::super::problems::{Reason, RowError};
use super::discover;
use super::frames::{SpectrumRow, SpectrumSink, MAX_CHANNELS};
use super::kept::Kept;
use super::shape_table::{refine, ShapeTable};
use crate::data::measurand::MAX_GRATINGS;
use crate::error::TrainerError;

/// One channel's detector: the windows of its gratings, each tagged with the caller's name of
/// the grating (`G`), found in every frame of the channel. The import's detection and the
/// simulator's spectrum chain both turn frames into peaks here.
pub(crate) struct ChannelDetector<G> {
    detector: PeakDetector<f64, MAX_GRATINGS>,
    gratings: Vec<G>,
}

impl<G: Copy> ChannelDetector<G> {
    /// A detector of `config` over the gratings' `windows`; `None` for more windows than a
    /// detector holds.
    pub(crate) fn new(
        config: DetectorConfig<f64>,
        windows: impl IntoIterator<Item = (G, Window<f64>)>,
    ) -> Option<Self> {
        let (gratings, windows): (Vec<G>, Vec<Window<f64>>) = windows.into_iter().unzip();
        Some(ChannelDetector { detector: PeakDetector::new(config, &windows)?, gratings })
    }

    /// The gratings and their windows, in the detector's order.
    pub(crate) fn windows(&self) -> impl Iterator<Item = (G, &Window<f64>)> {
        self.gratings.iter().copied().zip(self.detector.windows())
    }

    /// Each grating's peak in `spectrum` (a whole frame of the channel), with its window.
    pub(crate) fn detect(&self, spectrum: &Spectrum<'_, f64>) -> impl Iterator<Item = (G, &Window<f64>, Peak<f64>)> {
        self.windows().zip(self.detector.detect(spectrum)).filter_map(|((g, w), p)| Some((g, w, p?)))
    }
}

/// One channel's detector and its results.
struct Channel<T> {
    /// Per window, the map's grating index, or `None` when discovered (numbered at the end);
    /// `None` where discovery found more peaks than a detector holds (an error at the end).
    detector: Option<ChannelDetector<Option<usize>>>,
    /// Per window, per frame: the peak, `None` where the frame lacks this channel.
    peaks: Vec<Vec<Option<T>>>,
    /// Per frame: the line of this channel's spectrum (0 where the frame lacks it).
    lines: Vec<u64>,
    /// Per window, the grating's measured shape, when the map gives one.
    shapes: Vec<Option<ShapeTable>>,
    /// Peaks discovered in the first spectrum (discovery only).
    discovered: usize,
    /// Line of the channel's first spectrum.
    first_line: u64,
}

/// The detection of one file, fed row by row ([`SpectrumSink`]).
pub(crate) struct Detection<T> {
    config: DetectorConfig<f64>,
    /// The map's windows: (grating index, channel 0-based, window); empty: discovery.
    mapped: Vec<(usize, usize, Window<f64>)>,
    /// Per mapped grating, its measured shape ([`super::shape`]).
    shapes: Vec<Option<ShapeTable>>,
    channels: Vec<Option<Channel<T>>>,
    t: Vec<f64>,
    lines: Vec<u64>,
    /// Channels already in the current frame.
    in_frame: Vec<bool>,
    /// The file's time and channel columns, for messages.
    columns: (&'static str, &'static str),
}

/// One grating's peaks over the frames.
pub(crate) struct GratingPeaks<T> {
    /// Channel, 0-based.
    pub channel: usize,
    /// Where it comes from, in words.
    pub source: String,
    /// Per frame (`None`: the frame lacks the channel).
    pub peaks: Vec<Option<T>>,
    /// Per frame: the line of the channel's spectrum (0 where the frame lacks it).
    pub lines: Vec<u64>,
    /// Per frame: the peak is not one the grating can make (`plausible.rs`): a fault.
    pub implausible: Vec<bool>,
    /// Its peaks are refined by a measured shape the map gives (`[[grating]] shape`).
    pub shaped: bool,
}

/// Every frame's time and line, and the gratings' peaks in dataset order.
pub(crate) struct Detected<T> {
    /// Time of each frame on the file's axis \[s\].
    pub t: Vec<f64>,
    /// Line of each frame's first spectrum.
    pub lines: Vec<u64>,
    /// dl1, dl2, … in order.
    pub gratings: Vec<GratingPeaks<T>>,
    /// The windows came from the map (else discovered).
    pub from_map: bool,
}

impl<T: Kept> Detection<T> {
    /// A detection with `config` and the map's windows (none: discovery), each grating's
    /// measured shape read (errors name the map `origin`, the key and the scan's file);
    /// `columns` name the file's time and channel columns in messages.
    pub(crate) fn new(
        config: DetectorConfig<f64>,
        windows: &[mapping::Window],
        origin: &str,
        columns: (&'static str, &'static str),
    ) -> Result<Self, TrainerError> {
        let mapped = windows.iter().enumerate().map(|(g, w)| (g, w.channel, Window::new(w.lo, w.hi))).collect();
        // A scan's own errors name its file, line and column; the map's key says which grating.
        let load = |w: &mapping::Window| {
            let shape = w.shape.as_deref().map(super::shape::load).transpose();
            shape.map_err(|e| TrainerError::Config {
                origin: origin.to_string(),
                key: format!("{}.shape", w.key),
                message: e.to_string(),
            })
        };
        let shapes = windows.iter().map(load).collect::<Result<_, _>>()?;
        Ok(Detection {
            config,
            mapped,
            shapes,
            channels: Vec::new(),
            t: Vec::new(),
            lines: Vec::new(),
            in_frame: Vec::new(),
            columns,
        })
    }

    /// True before the first spectrum.
    pub(crate) fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The channel's state, made at its first spectrum (`None` only past [`MAX_CHANNELS`],
    /// which the caller refuses first).
    fn channel(&mut self, row: &SpectrumRow<'_>) -> Option<&mut Channel<T>> {
        let c = row.channel;
        if self.channels.len() <= c {
            self.channels.resize_with(c + 1, || None);
        }
        let frames = self.t.len();
        let config = self.config;
        let (mapped, shapes) = (&self.mapped, &self.shapes);
        let slot = self.channels.get_mut(c)?;
        Some(slot.get_or_insert_with(|| {
            let windows: Vec<(Option<usize>, Window<f64>)> = if mapped.is_empty() {
                discover::windows(&row.spectrum, &config).into_iter().map(|w| (None, w)).collect()
            } else {
                mapped.iter().filter(|m| m.1 == c).map(|m| (Some(m.0), m.2)).collect()
            };
            let discovered = if mapped.is_empty() { windows.len() } else { 0 };
            let shapes = windows.iter().map(|(g, _)| g.and_then(|g| shapes.get(g).cloned().flatten())).collect();
            let detector = ChannelDetector::new(config, windows);
            let n = detector.as_ref().map_or(0, |d| d.windows().count());
            Channel {
                detector,
                shapes,
                peaks: vec![vec![None; frames]; n],
                lines: vec![0; frames],
                discovered,
                first_line: row.line,
            }
        }))
    }

    /// The results, with the gratings in dataset order: the map's, or without a map each
    /// channel's discovered peaks in wavelength order, channel after channel. `name` and
    /// `origin` name the file and the map in errors.
    pub(crate) fn finish(self, name: &str, origin: &str, channels_in_file: usize) -> Result<Detected<T>, TrainerError> {
        let from_map = !self.mapped.is_empty();
        if from_map {
            if let Some((g, c, _)) = self.mapped.iter().find(|m| m.1 >= channels_in_file) {
                return Err(TrainerError::Config {
                    origin: origin.to_string(),
                    key: format!("grating[{}].channel", g + 1),
                    message: format!("channel {} but {name} has {channels_in_file} channels", c + 1),
                });
            }
        }
        let frames = self.t.len();
        let mut out: Vec<(usize, GratingPeaks<T>)> = Vec::new();
        let total: usize = self.channels.iter().flatten().map(|c| c.discovered).sum();
        if !from_map && (total == 0 || total > MAX_GRATINGS) {
            let counts: Vec<String> = self
                .channels
                .iter()
                .enumerate()
                .filter_map(|(c, s)| {
                    s.as_ref().map(|s| format!("channel {}: {} (line {})", c + 1, s.discovered, s.first_line))
                })
                .collect();
            return Err(TrainerError::data(
                name,
                self.lines.first().copied().unwrap_or(1),
                self.columns.1,
                format!(
                    "without --map the peaks of each channel's first spectrum become gratings, and 1 to {MAX_GRATINGS} are supported; found {total} ({}): give a map with one [[grating]] entry (channel, window_nm) per grating",
                    counts.join(", ")
                ),
            ));
        }
        let mut next = 0;
        for (c, ch) in self.channels.into_iter().enumerate() {
            let Some(ch) = ch else { continue };
            let Some(det) = ch.detector else { continue };
            let mut lines = ch.lines;
            lines.resize(frames, 0);
            for (((g, w), peaks), shape) in det.windows().zip(ch.peaks).zip(&ch.shapes) {
                let (index, source) = match g {
                    Some(g) => (g, format!("channel {}, window {}–{} nm", c + 1, w.lo_nm, w.hi_nm)),
                    None => {
                        next += 1;
                        (
                            next - 1,
                            format!(
                                "channel {}, window {:.3}–{:.3} nm around a peak of its first spectrum (line {}; no map)",
                                c + 1,
                                w.lo_nm,
                                w.hi_nm,
                                ch.first_line
                            ),
                        )
                    }
                };
                let mut peaks = peaks;
                peaks.resize(frames, None);
                let implausible = super::plausible::implausible(&peaks);
                let shaped = shape.is_some();
                out.push((
                    index,
                    GratingPeaks { channel: c, source, peaks, lines: lines.clone(), implausible, shaped },
                ));
            }
        }
        // A mapped grating whose channel never had a spectrum: gaps throughout.
        for (g, c, w) in &self.mapped {
            if !out.iter().any(|(i, _)| i == g) {
                let source =
                    format!("channel {}, window {}–{} nm (no spectrum of the channel)", c + 1, w.lo_nm, w.hi_nm);
                let (peaks, lines, implausible) = (vec![None; frames], vec![0; frames], vec![false; frames]);
                let shaped = self.shapes.get(*g).is_some_and(Option::is_some);
                out.push((*g, GratingPeaks { channel: *c, source, peaks, lines, implausible, shaped }));
            }
        }
        out.sort_by_key(|(i, _)| *i);
        Ok(Detected { t: self.t, lines: self.lines, gratings: out.into_iter().map(|(_, g)| g).collect(), from_map })
    }
}

impl<T: Kept> SpectrumSink for Detection<T> {
    fn spectrum(&mut self, row: SpectrumRow<'_>) -> Result<(), RowError> {
        if row.channel >= MAX_CHANNELS {
            return Err(RowError::new(
                Reason::NonNumeric,
                row.line,
                self.columns.1,
                format!("channel {} is beyond the {MAX_CHANNELS} supported", row.channel + 1),
            ));
        }
        let new_frame = match self.t.last() {
            None => true,
            Some(&prev) if row.t > prev => true,
            Some(&prev) if row.t < prev => {
                let prev_line = self.lines.last().copied().unwrap_or(0);
                return Err(RowError::new(
                    Reason::TimeBackwards,
                    row.line,
                    self.columns.0,
                    format!("time goes backwards: {} s is earlier than the frame of line {prev_line}", row.t),
                ));
            }
            Some(_) => false,
        };
        if !new_frame && self.in_frame.get(row.channel).copied().unwrap_or(false) {
            return Err(RowError::new(
                Reason::DuplicateTime,
                row.line,
                self.columns.1,
                format!(
                    "channel {} twice in the frame at {} s (a frame holds each channel once)",
                    row.channel + 1,
                    row.t
                ),
            ));
        }
        if new_frame {
            self.t.push(row.t);
            self.lines.push(row.line);
            self.in_frame.clear();
            for ch in self.channels.iter_mut().flatten() {
                for p in &mut ch.peaks {
                    p.push(None);
                }
                ch.lines.push(0);
            }
        }
        if self.in_frame.len() <= row.channel {
            self.in_frame.resize(row.channel + 1, false);
        }
        if let Some(seen) = self.in_frame.get_mut(row.channel) {
            *seen = true;
        }
        let Some(ch) = self.channel(&row) else { return Ok(()) };
        if let Some(l) = ch.lines.last_mut() {
            *l = row.line;
        }
        if let Some(det) = &ch.detector {
            for ((slot, (_, w, mut p)), shape) in ch.peaks.iter_mut().zip(det.detect(&row.spectrum)).zip(&ch.shapes) {
                // The measured shape refines the method's estimate; no shape fits: no peak.
                if let Some(t) = shape.as_ref().and_then(ShapeTable::template) {
                    p.wavelength_nm = refine(&row.spectrum, w, &t, p.pixel).unwrap_or(f64::NAN);
                    if p.wavelength_nm.is_nan() {
                        p.flags.insert(PeakFlags::NO_PEAK);
                    }
                }
                if let Some(last) = slot.last_mut() {
                    *last = Some(T::from(p));
                }
            }
        }
        Ok(())
    }
}
