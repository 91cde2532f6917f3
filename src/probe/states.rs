//! The device's speed states, and timings labelled by them.
//!
//! A shared machine does not run at one speed. On this project's VM the probe's frames
//! showed two states that the device switches between every few seconds: in one, the
//! empty shader over the screen (clear, depth test, framebuffer writes: memory traffic)
//! takes 1.5 ms, in the other 3.1 ms, while 16 bilinear lookups move by 10 % and the frame
//! that shades nothing by 0.4 ms — a slowdown additive per frame and uneven across kinds of
//! work, so no single scale factor corrects it (one over-corrects the rows bound by ALU
//! and uniform reads). Within a state the same frames repeat to ±3 %.
//!
//! So the probe and the bench time every point or row in segments of frames with one
//! **monitor** frame (the empty shader over the screen, the most state-sensitive point)
//! after each: a segment whose monitor frames before and after fall in the same state ran
//! in it. [`DeviceStates::from_monitor`] tells the states apart from the probe's monitor
//! frames (two clusters of log-times by 2-means, kept apart where their centres differ by
//! more than [`STATE_RATIO`]; else one state). The probe fits a model to the points'
//! frames in each state it has frames of every point in (the main one, whose model
//! `probe.md` and `table.json` report first: the fastest of those, the device least
//! disturbed; else the state most monitor frames fell in), and a row's `x_model` compares
//! its frames in the fastest modelled state it ran in with that state's model: like with
//! like, whichever state the device was in when. A dedicated device has one state, and
//! every frame counts.
//!
//! Two more things the traces showed. The first frame after a long segment of heavy work is
//! often slow when the next is not (32 of 600 monitor frames of one probe crossed the
//! threshold that way, 1 the other way; the second frame after: 4 against 3), so a monitor
//! reading is one untimed frame, then the timed one. And one **build** of a pipeline can
//! run a shader ≈ 25 % slower than another build of the same SPIR-V for as long as it lives
//! (128 uniform reads: 70.7–77.5 ms over 20 segments on two builds, 57.3–61.6 on the third,
//! in both states) — where the JIT put its code, by the look of it, not the shader's
//! cost. So every segment says which build it timed, and a point's or row's time in a state
//! is the median of its fastest build there ([`Segmented::median_in`]).

use serde::{Deserialize, Serialize};

use crate::gpu::TimingStats;

/// Monitor clusters closer than this ratio of their centres are one state.
pub const STATE_RATIO: f64 = 1.25;

/// How far (relative) the second-fastest build of a probe point or bench row, in the state
/// it is measured in, may run from the fastest for the two to agree
/// ([`Segmented::builds_agree_in`]): most builds agree within 5 %, an odd one runs 13–37 %
/// slow.
pub const BUILD_AGREEMENT: f64 = 0.1;

/// The speed states the probe's monitor frames fell into.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeviceStates {
    /// Each state's median monitor frame, ms, fastest first (one entry: one state).
    pub monitor_ms: Vec<f64>,
    /// Monitor frames at or above this are the slower state (`None`: one state).
    pub threshold_ms: Option<f64>,
    /// Monitor frames above this are spikes, in no state (a frame that met a hiccup of
    /// the host; the segments on either side of it do not count).
    pub spike_ms: f64,
    /// Share of the probe's monitor frames in each state.
    pub shares: Vec<f64>,
    /// The state whose model is the probe's main one: from the monitor frames alone the
    /// state with most of them; the probe makes it the fastest state that every point has
    /// frames in, where there is one (the device least disturbed).
    pub main_state: usize,
}

impl DeviceStates {
    /// One state: every frame counts.
    pub fn single(monitor_ms: f64) -> Self {
        DeviceStates {
            monitor_ms: vec![monitor_ms],
            threshold_ms: None,
            spike_ms: f64::INFINITY,
            shares: vec![1.0],
            main_state: 0,
        }
    }

    /// The states of a device from its monitor frames (module doc). Non-finite or
    /// non-positive frames are ignored; without any, one state.
    pub fn from_monitor(monitor: &[f64]) -> Self {
        let mut logs: Vec<f64> = monitor
            .iter()
            .filter(|m| m.is_finite() && **m > 0.0)
            .map(|m| m.ln())
            .collect();
        logs.sort_by(f64::total_cmp);
        let median_ms = |l: &[f64]| {
            let ms: Vec<f64> = l.iter().map(|v| v.exp()).collect();
            TimingStats::from_ms(&ms).map_or(f64::NAN, |t| t.ms_median)
        };
        if logs.len() < 2 {
            return DeviceStates::single(median_ms(&logs));
        }
        // Spikes: beyond the upper quartile by three interquartile ranges (at least 10 %
        // each) in log-time; a slower state that rare is left out with them.
        let quartile = |q: f64| logs[((logs.len() - 1) as f64 * q).round() as usize];
        let spread = (quartile(0.75) - quartile(0.25)).max(1.1f64.ln());
        let spike_log = quartile(0.75) + 3.0 * spread;
        logs.retain(|&l| l <= spike_log);
        let spike_ms = spike_log.exp();
        let single = |logs: &[f64]| DeviceStates {
            spike_ms,
            ..DeviceStates::single(median_ms(logs))
        };
        // 2-means in one dimension: the best split of the sorted values.
        let n = logs.len();
        let mut prefix = vec![0.0; n + 1];
        let mut prefix_sq = vec![0.0; n + 1];
        for (i, l) in logs.iter().enumerate() {
            prefix[i + 1] = prefix[i] + l;
            prefix_sq[i + 1] = prefix_sq[i] + l * l;
        }
        let sse = |a: usize, b: usize| {
            let (s, q, k) = (
                prefix[b] - prefix[a],
                prefix_sq[b] - prefix_sq[a],
                (b - a) as f64,
            );
            q - s * s / k
        };
        let split = (1..n)
            .min_by(|&a, &b| (sse(0, a) + sse(a, n)).total_cmp(&(sse(0, b) + sse(b, n))))
            .unwrap_or(1);
        let (fast, slow) = logs.split_at(split);
        let mean = |l: &[f64]| l.iter().sum::<f64>() / l.len() as f64;
        if (mean(slow) - mean(fast)).exp() < STATE_RATIO {
            return single(&logs);
        }
        let shares = vec![fast.len() as f64 / n as f64, slow.len() as f64 / n as f64];
        DeviceStates {
            monitor_ms: vec![median_ms(fast), median_ms(slow)],
            // Halfway between the clusters' edges, in log-time.
            threshold_ms: Some((0.5 * (fast[fast.len() - 1] + slow[0])).exp()),
            spike_ms,
            main_state: usize::from(shares[1] > shares[0]),
            shares,
        }
    }

    /// The state a monitor frame was in (`None` for a missing one or a spike).
    pub fn state_of(&self, monitor_ms: f64) -> Option<usize> {
        if !monitor_ms.is_finite() || monitor_ms > self.spike_ms {
            return None;
        }
        Some(match self.threshold_ms {
            Some(t) if monitor_ms >= t => 1,
            _ => 0,
        })
    }

    /// Whether a segment between these monitor frames ran in `state`.
    pub fn ran_in(&self, segment: &Segment, state: usize) -> bool {
        let before = self.state_of(segment.monitor_before);
        before == Some(state) && before == self.state_of(segment.monitor_after)
    }

    /// How many states.
    pub fn count(&self) -> usize {
        self.monitor_ms.len()
    }

    /// Share of these monitor frames in each state.
    pub fn shares_of(&self, monitor: &[f64]) -> Vec<f64> {
        let mut counts = vec![0usize; self.monitor_ms.len()];
        for s in monitor.iter().filter_map(|&m| self.state_of(m)) {
            counts[s] += 1;
        }
        let total = counts.iter().sum::<usize>().max(1) as f64;
        counts.iter().map(|&c| c as f64 / total).collect()
    }

    /// Shares as "15 % / 85 %".
    pub fn format_shares(shares: &[f64]) -> String {
        shares
            .iter()
            .map(|s| format!("{:.0} %", 100.0 * s))
            .collect::<Vec<_>>()
            .join(" / ")
    }

    /// One line for the reports.
    pub fn describe(&self) -> String {
        let spikes = if self.spike_ms.is_finite() {
            format!("; monitor frames above {:.3} ms are spikes", self.spike_ms)
        } else {
            String::new()
        };
        let states = match self.threshold_ms {
            None => format!(
                "one speed state (monitor frame {:.3} ms)",
                self.monitor_ms[0]
            ),
            Some(t) => format!(
                "two speed states (monitor frame {:.3} ms in {:.0} % of the probe's monitor frames, {:.3} ms in {:.0} %; threshold {:.3} ms); the main model is the {} state's",
                self.monitor_ms[0],
                100.0 * self.shares[0],
                self.monitor_ms[1],
                100.0 * self.shares[1],
                t,
                if self.main_state == 0 {
                    "faster"
                } else {
                    "slower"
                }
            ),
        };
        states + &spikes
    }
}

/// Frames timed in one go, with the monitor frames around them (NaN: none).
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Which build of the pipeline timed them (module doc): segments of one build pool.
    pub build: usize,
    pub monitor_before: f64,
    pub ms: Vec<f64>,
    pub monitor_after: f64,
}

/// A point's or row's segments.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Segmented(pub Vec<Segment>);

impl Segmented {
    pub fn push(&mut self, build: usize, monitor_before: f64, ms: Vec<f64>, monitor_after: f64) {
        self.0.push(Segment {
            build,
            monitor_before,
            ms,
            monitor_after,
        });
    }

    /// The monitor frames around its segments.
    pub fn monitor_frames(&self) -> impl Iterator<Item = f64> + '_ {
        self.0
            .iter()
            .flat_map(|s| [s.monitor_before, s.monitor_after])
    }

    /// Every frame.
    pub fn all(&self) -> Vec<f64> {
        self.0.iter().flat_map(|s| s.ms.iter().copied()).collect()
    }

    /// The frames of the segments that ran in `state`.
    pub fn ran_in(&self, states: &DeviceStates, state: usize) -> Vec<f64> {
        self.0
            .iter()
            .filter(|s| states.ran_in(s, state))
            .flat_map(|s| s.ms.iter().copied())
            .collect()
    }

    /// The median of the frames in `state` of the build whose median there is lowest
    /// (module doc), and how many frames of every build ran in `state`.
    pub fn median_in(&self, states: &DeviceStates, state: usize) -> (Option<f64>, usize) {
        self.fastest_build(|s| states.ran_in(s, state))
    }

    /// Whether the two fastest builds with frames in `state` agree: the second's median
    /// within `tolerance` (relative) of the first's. A row's time there is its fastest
    /// build's; a second build close to it says that build is not the odd one (builds of
    /// one pipeline ran 1.00×, 1.18× and 1.37× the fastest — pca12v25, one bench — where
    /// most rows' builds agree within 5 %). Only builds with at least `min_frames` frames
    /// in `state` count: two builds of a frame or two each can agree by chance. False with
    /// fewer than two such builds.
    pub fn builds_agree_in(
        &self,
        states: &DeviceStates,
        state: usize,
        tolerance: f64,
        min_frames: usize,
    ) -> bool {
        match self.build_medians(|s| states.ran_in(s, state), min_frames)[..] {
            [fastest, second, ..] => second <= fastest * (1.0 + tolerance),
            _ => false,
        }
    }

    /// The median of every frame of its fastest build, whatever state it ran in.
    pub fn fastest_build_median(&self) -> Option<f64> {
        self.fastest_build(|_| true).0
    }

    /// The lowest of the builds' medians over the segments `keep` keeps, and the frames kept.
    fn fastest_build(&self, keep: impl Fn(&Segment) -> bool) -> (Option<f64>, usize) {
        let frames = self.0.iter().filter(|s| keep(s)).map(|s| s.ms.len()).sum();
        (self.build_medians(keep, 1).first().copied(), frames)
    }

    /// Each build's median over the segments `keep` keeps, of the builds with at least
    /// `min_frames` frames there, fastest first.
    fn build_medians(&self, keep: impl Fn(&Segment) -> bool, min_frames: usize) -> Vec<f64> {
        let kept: Vec<&Segment> = self.0.iter().filter(|s| keep(s)).collect();
        let mut builds: Vec<usize> = kept.iter().map(|s| s.build).collect();
        builds.sort_unstable();
        builds.dedup();
        let mut medians: Vec<f64> = builds
            .into_iter()
            .filter_map(|b| {
                let frames: Vec<f64> = kept
                    .iter()
                    .filter(|s| s.build == b)
                    .flat_map(|s| s.ms.iter().copied())
                    .collect();
                if frames.len() < min_frames {
                    return None;
                }
                TimingStats::from_ms(&frames).map(|t| t.ms_median)
            })
            .collect();
        medians.sort_by(f64::total_cmp);
        medians
    }

    /// The fastest state among `candidates` that any of these frames ran in (the device
    /// least disturbed, as the probe's main model), with their median ([`Self::median_in`])
    /// and count; `None` where none ran in any.
    pub fn fastest_state(
        &self,
        states: &DeviceStates,
        candidates: impl IntoIterator<Item = usize>,
    ) -> Option<(usize, f64, usize)> {
        candidates
            .into_iter()
            .filter_map(|s| match self.median_in(states, s) {
                (Some(ms), n) => Some((s, ms, n)),
                (None, _) => None,
            })
            // States are numbered fastest first.
            .min_by_key(|&(s, _, _)| s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_monitor_clusters_are_two_states_and_the_commoner_is_the_main_one() {
        let monitor = [3.1, 3.15, 1.55, 3.2, 3.05, 3.12, 3.3, 3.12, 7.3];
        let states = DeviceStates::from_monitor(&monitor);
        assert_eq!(states.monitor_ms.len(), 2, "{states:?}");
        let t = states.threshold_ms.unwrap();
        assert!(t > 1.55 && t < 3.05, "{states:?}");
        assert_eq!(states.main_state, 1, "{states:?}");
        let fast = DeviceStates::from_monitor(&[3.1, 1.5, 1.6, 3.2, 1.5, 1.55, 1.6]);
        assert_eq!(fast.main_state, 0, "{fast:?}");
        let seg = |a: f64, b: f64| Segment {
            build: 0,
            monitor_before: a,
            ms: vec![10.0],
            monitor_after: b,
        };
        assert!(states.spike_ms < 7.3, "{states:?}");
        assert!(states.ran_in(&seg(3.1, 3.2), 1));
        assert!(!states.ran_in(&seg(3.1, 7.3), 1), "a spike is in no state");
        assert!(!states.ran_in(&seg(1.5, 3.2), 0), "a switch inside");
        assert!(!states.ran_in(&seg(1.5, 3.2), 1), "a switch inside");
        assert!(states.ran_in(&seg(1.5, 1.6), 0));
        assert!(!states.ran_in(&seg(f64::NAN, 3.2), 1));
    }

    #[test]
    fn monitor_frames_within_the_ratio_are_one_state() {
        let states = DeviceStates::from_monitor(&[3.0, 3.3, 2.9, 3.1, 3.5, 3.2]);
        assert_eq!(states.threshold_ms, None, "{states:?}");
        assert!((states.monitor_ms[0] - 3.15).abs() < 1e-9, "{states:?}");
    }

    #[test]
    fn a_row_is_compared_in_the_fastest_state_it_ran_in() {
        let states = DeviceStates::from_monitor(&[1.0, 1.0, 2.0, 2.0]);
        let mut row = Segmented::default();
        row.push(0, 2.0, vec![9.0, 11.0], 2.0);
        row.push(0, 1.0, vec![5.0], 1.0);
        row.push(0, 1.0, vec![50.0], 2.0);
        assert_eq!(row.median_in(&states, 0), (Some(5.0), 1));
        assert_eq!(row.fastest_state(&states, [1, 0]), Some((0, 5.0, 1)));
        assert_eq!(row.fastest_state(&states, [1]), Some((1, 10.0, 2)));
        assert_eq!(Segmented::default().fastest_state(&states, [0, 1]), None);
    }

    #[test]
    fn a_slow_build_does_not_set_the_time_but_its_frames_count() {
        let states = DeviceStates::single(1.0);
        let mut point = Segmented::default();
        point.push(0, 1.0, vec![73.0, 74.0, 72.0], 1.0);
        point.push(1, 1.0, vec![58.0, 61.0], 1.0);
        point.push(0, 1.0, vec![75.0], 1.0);
        point.push(1, 1.0, vec![59.0], 1.0);
        assert_eq!(point.median_in(&states, 0), (Some(59.0), 7));
        // 59 against 74: the fastest two builds disagree (a third is asked for) by 25 %.
        assert!(!point.builds_agree_in(&states, 0, 0.1, 1));
        assert!(point.builds_agree_in(&states, 0, 0.3, 1));
        point.push(2, 1.0, vec![62.0, 63.0], 1.0);
        assert!(point.builds_agree_in(&states, 0, 0.1, 1));
        // Asked for three frames a build: build 2's two do not count, and 59 against 74
        // disagree again.
        assert!(!point.builds_agree_in(&states, 0, 0.1, 3));
        point.push(2, 1.0, vec![61.0], 1.0);
        assert!(point.builds_agree_in(&states, 0, 0.1, 3));
        assert_eq!(point.median_in(&states, 0).0, Some(59.0));
        let two = DeviceStates::from_monitor(&[1.0, 1.0, 2.0, 2.0]);
        let mut row = Segmented::default();
        row.push(0, 1.0, vec![60.0], 1.0);
        row.push(1, 2.0, vec![70.0], 2.0);
        // One build in each state: none agrees with another, however loose the tolerance.
        assert!(!row.builds_agree_in(&two, 0, 1.0, 1) && !row.builds_agree_in(&two, 1, 1.0, 1));
        assert_eq!(point.fastest_build_median(), Some(59.0));
        // One build: the median of all its frames.
        let mut one = Segmented::default();
        one.push(3, 1.0, vec![10.0, 30.0], 1.0);
        one.push(3, 1.0, vec![20.0], 1.0);
        assert_eq!(one.median_in(&states, 0), (Some(20.0), 3));
    }
}
