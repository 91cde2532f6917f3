//! What `shvis view` says when its window closes: the frame times, each technique × path
//! shown, and the lighting rebuilds.

use super::ViewReport;

/// `—` for a missing figure, else `f` of it.
fn or_dash(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map_or("—".into(), f)
}

impl ViewReport {
    /// The run's summary, one line per item (each ending in a newline).
    pub fn summary(&self) -> String {
        let mut text = format!(
            "view on {} ({} present): median frame {} ms, longest {} ms\n",
            self.device,
            self.present_mode,
            or_dash(self.median_frame_ms, |m| format!("{m:.2}")),
            or_dash(self.longest_frame_ms, |m| format!("{m:.2}")),
        );
        for (label, frames, wall, gpu) in &self.shown {
            text += &format!(
                "  {label}: {frames} frames, {} a frame ({} frames/s), GPU {}\n",
                or_dash(*wall, |w| format!("{w:.2} ms")),
                or_dash(*wall, |w| format!("{:.1}", 1e3 / w)),
                or_dash(*gpu, |g| format!("{g:.2} ms"))
            );
        }
        text += &format!(
            "  lighting rebuilds swapped in: {} (CPU build median {}), longest frame that swapped one in {} ms\n",
            self.rebuilds,
            or_dash(self.rebuild_cpu_ms, |m| format!("{m:.1} ms")),
            or_dash(self.longest_swap_frame_ms, |m| format!("{m:.2}"))
        );
        text
    }
}
