//! How frames are timed so that a fast GPU's frames are measured honestly.
//!
//! A frame's time is the span between two GPU timestamps around its render pass, in ticks of
//! `timestampPeriod` ns, each submission waited for (`gpu::pass`). On a CPU rasterizer a frame
//! takes milliseconds and one frame per query is exact. On a current GPU a 1280×800 frame
//! can take 0.05 ms: between two waited submissions the GPU idles and its clocks fall, so
//! single frames are timed at a clock the frame never runs at in a game, and the fixed cost
//! of a render pass's start weighs on each. So:
//!
//! - **Draws per query.** The last warm-up frame's time `t` picks `n` = ⌈[`MIN_QUERY_SPAN_MS`]
//!   / t⌉ (at most [`MAX_DRAWS_PER_QUERY`]) repetitions of the frame's render pass between
//!   the two timestamps, and a frame's time is the span ÷ n: the GPU stays busy for at least
//!   half a millisecond per query, well above the timer's resolution (the span is also at
//!   least [`MIN_TICKS_PER_QUERY`] ticks on a coarse timer). Frames of half a millisecond and
//!   more (every frame on lavapipe) keep one frame per query.
//! - **Settling.** With several draws per query, queries run until the median of the last
//!   [`SETTLE_WINDOW`] is within [`SETTLE_TOLERANCE`] of the window before it (the clocks have
//!   ramped up), at most [`MAX_SETTLE_QUERIES`], before the timed ones.
//! - **Spread.** Every timed query is kept: the bench reports median, minimum and maximum.
//!
//! A timestamp counter of fewer than 64 valid bits wraps; [`ticks_to_ms`] tolerates one wrap.

/// A query spans at least this long (ms) when its frame is shorter.
pub const MIN_QUERY_SPAN_MS: f64 = 0.5;
/// …and at least this many timer ticks.
pub const MIN_TICKS_PER_QUERY: f64 = 1000.0;
/// Repetitions of a frame per query, at most.
pub const MAX_DRAWS_PER_QUERY: u32 = 64;
/// Queries whose median is compared with the window before it while settling.
pub const SETTLE_WINDOW: usize = 4;
/// Relative change of that median under which the clocks count as settled.
pub const SETTLE_TOLERANCE: f64 = 0.03;
/// Settling queries, at most.
pub const MAX_SETTLE_QUERIES: usize = 48;

/// Draws per query for a frame that took `frame_ms` alone, on a timer of `ns_per_tick`, so
/// that a query spans at least `min_span_ms` ([`MIN_QUERY_SPAN_MS`] but in tests).
pub fn draws_per_query(frame_ms: f64, ns_per_tick: f64, min_span_ms: f64) -> u32 {
    let span_ms = min_span_ms.max(MIN_TICKS_PER_QUERY * ns_per_tick * 1e-6);
    if frame_ms.is_nan() || frame_ms <= 0.0 || frame_ms >= span_ms {
        return 1;
    }
    ((span_ms / frame_ms).ceil() as u32).clamp(1, MAX_DRAWS_PER_QUERY)
}

/// Whether the per-frame times of the settling queries so far (oldest first) have settled:
/// the median of the last [`SETTLE_WINDOW`] within [`SETTLE_TOLERANCE`] of the window's
/// before it.
pub fn settled(ms: &[f64]) -> bool {
    if ms.len() < 2 * SETTLE_WINDOW {
        return false;
    }
    let last = median(&ms[ms.len() - SETTLE_WINDOW..]);
    let before = median(&ms[ms.len() - 2 * SETTLE_WINDOW..ms.len() - SETTLE_WINDOW]);
    before > 0.0 && ((last - before) / before).abs() <= SETTLE_TOLERANCE
}

/// The median of `values` (the mean of the middle two for an even count).
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Elapsed ms between two timestamps, tolerating one wrap of a `mask`-bit counter.
pub fn ticks_to_ms(start: u64, end: u64, mask: u64, ns_per_tick: f64) -> f64 {
    ((end & mask).wrapping_sub(start & mask) & mask) as f64 * ns_per_tick * 1e-6
}

/// The mask of a counter with `valid_bits` valid bits.
pub fn tick_mask(valid_bits: u32) -> u64 {
    match valid_bits {
        64.. => u64::MAX,
        bits => (1u64 << bits) - 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_wrap_once_within_valid_bits() {
        let mask = tick_mask(36);
        // 100 ticks across the wrap of a 36-bit counter, 1 ns each.
        let ms = ticks_to_ms(mask - 49, 50, mask, 1.0);
        assert!((ms - 100e-6).abs() < 1e-12, "{ms}");
        assert_eq!(tick_mask(64), u64::MAX);
    }

    #[test]
    fn slow_frames_keep_one_draw_and_fast_ones_fill_half_a_millisecond() {
        // lavapipe's frames (milliseconds) and frames at the span: one draw.
        for ms in [40.0, 2.0, MIN_QUERY_SPAN_MS] {
            assert_eq!(draws_per_query(ms, 1.0, MIN_QUERY_SPAN_MS), 1, "{ms} ms");
        }
        // A 0.05 ms frame on a 1 ns timer: 10 draws make 0.5 ms.
        assert_eq!(draws_per_query(0.05, 1.0, MIN_QUERY_SPAN_MS), 10);
        assert_eq!(draws_per_query(0.3, 1.0, MIN_QUERY_SPAN_MS), 2);
        // Far below: capped.
        assert_eq!(
            draws_per_query(1e-4, 1.0, MIN_QUERY_SPAN_MS),
            MAX_DRAWS_PER_QUERY
        );
        // A coarse timer (1 µs ticks) needs 1000 ticks = 1 ms per query.
        assert_eq!(draws_per_query(0.25, 1000.0, MIN_QUERY_SPAN_MS), 4);
        // No timing (0, NaN): one draw.
        assert_eq!(draws_per_query(0.0, 1.0, MIN_QUERY_SPAN_MS), 1);
        assert_eq!(draws_per_query(f64::NAN, 1.0, MIN_QUERY_SPAN_MS), 1);
        // Every frame draws at least the span once the draws are applied.
        for ms in [0.01, 0.07, 0.11, 0.49] {
            let n = draws_per_query(ms, 1.0, MIN_QUERY_SPAN_MS);
            assert!(
                f64::from(n) * ms >= MIN_QUERY_SPAN_MS - 1e-12,
                "{ms} ms × {n}"
            );
        }
    }

    #[test]
    fn clocks_settle_when_the_median_stops_moving() {
        // A ramp from 0.2 to 0.1 ms a frame: not settled while it falls.
        let ramp: Vec<f64> = (0..8).map(|i| 0.2 - 0.0125 * f64::from(i)).collect();
        assert!(!settled(&ramp));
        // Then flat (with 1 % noise): settled.
        let mut flat = ramp.clone();
        flat.extend([0.1, 0.101, 0.099, 0.1, 0.1, 0.1, 0.101, 0.099]);
        assert!(settled(&flat));
        // Too few queries to tell.
        assert!(!settled(&flat[..2 * SETTLE_WINDOW - 1]));
    }
}
