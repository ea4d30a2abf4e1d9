//! The static intervals of a raw stream: where the instrument was held still.
//!
//! The detector is `imu_tk`'s kind: the readings' variance in a moving window, summed over
//! the channels, against the same variance while the record starts at rest. A sample is
//! static when its window's variance is at most `threshold` times the rest's; a run of
//! static samples held at least `min_static_s` is an interval. The rest's level is the
//! median of its windows' variances, not the variance of the whole rest, so that a slow
//! drift during the rest does not raise it; a rest whose own windows exceed the threshold
//! is refused (the record does not start at rest).

use crate::output::significant as sig;

/// The detector's settings (`--rest-s`, `--static-window-s`, `--static-threshold`,
/// `--static-min-s`, `--static-trim-s`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Detector {
    /// How long the record starts at rest, s.
    pub rest_s: f64,
    /// The moving window's length, s.
    pub window_s: f64,
    /// The largest window variance still static, in times the rest's.
    pub threshold: f64,
    /// The shortest interval kept, s.
    pub min_static_s: f64,
    /// What each interval loses at each end before it is kept, s: the start and the end of
    /// a turn are too gentle for the window's variance to see, and a precise instrument
    /// (a loop's counts over seconds) sees them in its mean.
    pub trim_s: f64,
}

impl Default for Detector {
    fn default() -> Self {
        Detector {
            rest_s: 10.0,
            window_s: 1.0,
            threshold: 4.0,
            min_static_s: 1.0,
            trim_s: 0.0,
        }
    }
}

/// Fewest samples in the moving window.
pub const MIN_WINDOW: usize = 5;

/// A run of samples, `first..=last` (indices into the stream), with each channel's mean
/// and standard deviation over it.
#[derive(Clone, Debug, PartialEq)]
pub struct Interval {
    /// Its first sample.
    pub first: usize,
    /// Its last sample.
    pub last: usize,
    /// The first sample's time, s.
    pub t0_s: f64,
    /// The last sample's time, s.
    pub t1_s: f64,
    /// Each channel's mean over the run, in the channels' unit.
    pub mean: Vec<f64>,
    /// Each channel's standard deviation over the run (samples less one), same unit.
    pub std: Vec<f64>,
}

impl Interval {
    /// Its samples.
    #[must_use]
    pub fn samples(&self) -> usize {
        self.last - self.first + 1
    }

    /// How long it was held: its span and one sample interval, s.
    #[must_use]
    pub fn held_s(&self, dt_s: f64) -> f64 {
        self.t1_s - self.t0_s + dt_s
    }
}

/// What the detector found.
#[derive(Clone, Debug)]
pub struct Segmentation {
    /// The settings used.
    pub detector: Detector,
    /// The median sample interval, s.
    pub dt_s: f64,
    /// The window, samples.
    pub window: usize,
    /// The rest's level: the median of its windows' variances, summed over the channels
    /// (the channels' unit squared).
    pub rest_variance: f64,
    /// The static limit: `threshold` times `rest_variance`.
    pub limit_variance: f64,
    /// The static intervals held at least `min_static_s`, in time order (the rest first).
    pub intervals: Vec<Interval>,
    /// The static runs held less than `min_static_s`, in time order.
    pub short: Vec<Interval>,
    /// The share of the samples found static (in kept intervals or short runs).
    pub static_fraction: f64,
}

impl Segmentation {
    /// The settings as the flags that set them, for a file's comments: `--rest-s 10,
    /// --static-window-s 1 (100 samples), …`.
    #[must_use]
    pub fn settings(&self) -> String {
        let d = &self.detector;
        format!(
            "--rest-s {}, --static-window-s {} ({} samples), --static-threshold {}, --static-min-s {}, --static-trim-s {}",
            sig(d.rest_s, 6),
            sig(d.window_s, 6),
            self.window,
            sig(d.threshold, 6),
            sig(d.min_static_s, 6),
            sig(d.trim_s, 6)
        )
    }
}

/// The median of `v` (not empty).
fn median(mut v: Vec<f64>) -> f64 {
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The variance of every centred window of `w` samples, summed over `channels`; at the
/// ends, the first and the last whole window's. Each channel's window is slid with
/// Welford's update and summed afresh every 4096 samples (its rounding never builds up).
#[must_use]
pub fn moving_variance(channels: &[Vec<f64>], w: usize) -> Vec<f64> {
    let n = channels.first().map_or(0, Vec::len);
    let mut out = vec![0.0; n];
    if n < w || w < 2 {
        return out;
    }
    #[allow(clippy::cast_precision_loss)]
    let wf = w as f64;
    let h = w / 2;
    for x in channels {
        let exact = |s: usize| {
            let m = x[s..s + w].iter().sum::<f64>() / wf;
            let m2 = x[s..s + w].iter().map(|v| (v - m) * (v - m)).sum::<f64>();
            (m, m2)
        };
        let (mut m, mut m2) = exact(0);
        // Window s (samples s..s+w) belongs to sample s + h.
        for s in 0..=n - w {
            if s > 0 {
                if s % 4096 == 0 {
                    (m, m2) = exact(s);
                } else {
                    let (new, old) = (x[s + w - 1], x[s - 1]);
                    let m_next = m + (new - old) / wf;
                    m2 = (m2 + (new - old) * (new - m_next + old - m)).max(0.0);
                    m = m_next;
                }
            }
            out[s + h] += m2 / (wf - 1.0);
        }
    }
    let (lo, hi) = (out[h], out[n - w + h]);
    for v in &mut out[..h] {
        *v = lo;
    }
    for v in &mut out[n - w + h + 1..] {
        *v = hi;
    }
    out
}

/// The interval of samples `first..=last`.
fn interval(t: &[f64], channels: &[Vec<f64>], first: usize, last: usize) -> Interval {
    #[allow(clippy::cast_precision_loss)]
    let k = (last - first + 1) as f64;
    let mean: Vec<f64> = channels
        .iter()
        .map(|c| c[first..=last].iter().sum::<f64>() / k)
        .collect();
    let std = channels
        .iter()
        .zip(&mean)
        .map(|(c, m)| {
            let ss: f64 = c[first..=last].iter().map(|v| (v - m) * (v - m)).sum();
            if k > 1.0 {
                (ss / (k - 1.0)).sqrt()
            } else {
                0.0
            }
        })
        .collect();
    Interval {
        first,
        last,
        t0_s: t[first],
        t1_s: t[last],
        mean,
        std,
    }
}

/// The smallest step between successive readings of any channel: the readings'
/// resolution, where they are quantized.
fn resolution(channels: &[Vec<f64>], upto: usize) -> f64 {
    channels
        .iter()
        .flat_map(|c| c[..upto].windows(2).map(|w| (w[1] - w[0]).abs()))
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min)
}

/// The static intervals of the stream `t` (s, increasing) with `channels` (each as long as
/// `t`), by `d`.
///
/// # Errors
/// The window holds fewer than [`MIN_WINDOW`] samples; the rest is shorter than two
/// windows, or longer than the record; the rest is not at rest (a window of it beyond the
/// threshold: its time); the readings never change.
pub fn segment(t: &[f64], channels: &[Vec<f64>], d: &Detector) -> Result<Segmentation, String> {
    let n = t.len();
    if n < 2 {
        return Err(format!("{n} samples; expected a stream"));
    }
    let dt_s = median(t.windows(2).map(|w| w[1] - w[0]).collect());
    let samples = |s: f64| {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let k = (s / dt_s).round().max(0.0) as usize;
        k
    };
    let w = samples(d.window_s);
    if w < MIN_WINDOW {
        return Err(format!(
            "--static-window-s {}: {w} samples at the stream's {} s; expected at least {MIN_WINDOW} (a longer --static-window-s)",
            sig(d.window_s, 6),
            sig(dt_s, 6)
        ));
    }
    let rest = samples(d.rest_s).min(n);
    if rest < 2 * w {
        return Err(format!(
            "--rest-s {}: {rest} samples, shorter than two windows of {w} (--static-window-s {}); expected the record to start at rest for at least {} s",
            sig(d.rest_s, 6),
            sig(d.window_s, 6),
            sig(2.0 * d.window_s, 6)
        ));
    }
    if rest >= n {
        return Err(format!(
            "--rest-s {}: the whole stream ({} s); expected a rest at the start and positions after it",
            sig(d.rest_s, 6),
            sig(t[n - 1] - t[0] + dt_s, 6)
        ));
    }
    let v = moving_variance(channels, w);
    let h = w / 2;
    // The rest's windows: those wholly inside it.
    let mut level = median(v[h..=rest - w + h].to_vec());
    if level <= 0.0 {
        // Readings that do not change at rest: their quantization's variance.
        let q = resolution(channels, n);
        if !q.is_finite() {
            return Err("the readings never change; expected a stream of an instrument turned between positions".into());
        }
        #[allow(clippy::cast_precision_loss)]
        let floor = channels.len() as f64 * q * q / 12.0;
        level = floor;
    }
    let limit = d.threshold * level;
    if let Some(k) = (h..=rest - w + h).find(|&k| v[k] > limit) {
        return Err(format!(
            "--rest-s {}: the readings move at {} s, inside the rest (their variance over --static-window-s {} s is {}× the rest's median, beyond --static-threshold {}); expected the record to start at rest for --rest-s (a shorter --rest-s, or a larger --static-threshold)",
            sig(d.rest_s, 6),
            sig(t[k], 6),
            sig(d.window_s, 6),
            sig(v[k] / level, 3),
            sig(d.threshold, 6)
        ));
    }
    let trim = samples(d.trim_s);
    let (mut intervals, mut short) = (Vec::new(), Vec::new());
    let mut k = 0;
    let mut still = 0usize;
    while k < n {
        if v[k] > limit {
            k += 1;
            continue;
        }
        let first = k;
        while k < n && v[k] <= limit {
            k += 1;
        }
        still += k - first;
        let (a, b) = (first + trim, (k - 1).saturating_sub(trim));
        if a > b {
            short.push(interval(t, channels, first, k - 1));
            continue;
        }
        let run = interval(t, channels, a, b);
        if run.held_s(dt_s) >= d.min_static_s {
            intervals.push(run);
        } else {
            short.push(run);
        }
    }
    #[allow(clippy::cast_precision_loss)]
    let static_fraction = still as f64 / n as f64;
    Ok(Segmentation {
        detector: *d,
        dt_s,
        window: w,
        rest_variance: level,
        limit_variance: limit,
        intervals,
        short,
        static_fraction,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stream at 100 Hz: rest 10 s at 0, then holds of 3 s at levels 10, 20, ...
    /// joined by 1 s ramps, a small alternating noise on top.
    fn stream(holds: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
        let mut x = vec![0.0; 1000];
        let mut level = 0.0;
        for i in 1..=holds {
            #[allow(clippy::cast_precision_loss)]
            let next = 10.0 * i as f64;
            for s in 0..100 {
                x.push(level + (next - level) * f64::from(s) / 100.0);
            }
            level = next;
            x.extend(std::iter::repeat_n(level, 300));
        }
        #[allow(clippy::cast_precision_loss)]
        let t: Vec<f64> = (0..x.len()).map(|k| k as f64 * 0.01).collect();
        for (k, v) in x.iter_mut().enumerate() {
            #[allow(clippy::cast_precision_loss)]
            let wiggle = 1.0 + (k % 5) as f64 / 5.0;
            *v += if k % 2 == 0 { 0.01 } else { -0.01 } * wiggle;
        }
        (t, vec![x])
    }

    #[test]
    fn holds_are_found_and_ramps_are_not() {
        let (t, c) = stream(5);
        let s = segment(&t, &c, &Detector::default()).unwrap();
        assert_eq!(s.window, 100);
        assert_eq!(s.intervals.len(), 6, "{:?}", s.intervals);
        for (i, iv) in s.intervals.iter().enumerate() {
            #[allow(clippy::cast_precision_loss)]
            let level = 10.0 * i as f64;
            assert!((iv.mean[0] - level).abs() < 0.01, "{i}: {iv:?}");
            // A hold of 3 s less about a window: inside the hold, most of it.
            if i > 0 {
                assert!(iv.held_s(s.dt_s) > 1.9 && iv.held_s(s.dt_s) < 3.0, "{iv:?}");
            }
        }
        assert!(s.short.is_empty());
        let slow = Detector {
            min_static_s: 2.7,
            ..Detector::default()
        };
        let s = segment(&t, &c, &slow).unwrap();
        assert_eq!((s.intervals.len(), s.short.len()), (1, 5));
    }

    #[test]
    fn the_moving_variance_is_the_windows_variance() {
        let (_, c) = stream(10);
        let v = moving_variance(&c, 37);
        for k in [18, 500, 1100, 4096 + 18, c[0].len() - 19] {
            let win = &c[0][k - 18..k + 19];
            let m = win.iter().sum::<f64>() / 37.0;
            let want = win.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / 36.0;
            assert!((v[k] - want).abs() <= 1e-6 * want, "{k}: {} {want}", v[k]);
        }
    }

    #[test]
    fn a_rest_that_moves_and_bad_settings_are_refused() {
        let (t, mut c) = stream(3);
        c[0][500] += 5.0;
        let e = segment(&t, &c, &Detector::default()).unwrap_err();
        assert!(
            e.contains("the readings move at 4.") && e.contains("inside the rest"),
            "{e}"
        );
        let e = segment(
            &t,
            &c,
            &Detector {
                window_s: 0.03,
                ..Detector::default()
            },
        )
        .unwrap_err();
        assert!(e.contains("3 samples"), "{e}");
        let e = segment(
            &t,
            &c,
            &Detector {
                rest_s: 100.0,
                ..Detector::default()
            },
        )
        .unwrap_err();
        assert!(e.contains("the whole stream"), "{e}");
    }
}
