//! The probe as markdown (what `shvis probe` prints, and `probe.md`): the device and
//! settings, the main model's costs, the speed states and each one's model, and every point
//! against its prediction.

use super::Probe;
use super::schedule::{
    MIN_STATE_FRAMES, MIN_STATE_ROUNDS, RETIME_BATCHES, RETIME_ERROR, STATE_MODEL_SHARE,
};
use super::states::BUILD_AGREEMENT;
use crate::cost::Kind;

impl Probe {
    /// The probe as markdown: the model's costs and every point against its prediction.
    pub fn to_markdown(&self) -> String {
        let m = &self.model;
        let mut s = format!(
            "device: {} · {}×{} ({} fragments shaded by the screen grid of 2·{}² triangles, {:.0} pixels each) · at least {} timed frames per point (more for cheap ones), in interleaved rounds · {:.1} s, measured {} UTC{}\n\n\
             fixed {:.3} ms per frame; {:.3} µs per triangle, {:.2} ns more per varying float it carries; {:.3} ns per pixel of triangle edge; empty shader {:.3} ms per screen of lanes, of which the depth test {:.3} ms\n\n\
             | kind | ms per unit per screen of lanes | ns per unit per lane |\n|---|---:|---:|\n",
            self.device,
            self.width,
            self.height,
            self.screen_fragments,
            self.grid,
            0.72 * f64::from(self.width) * f64::from(self.height)
                / f64::from(self.grid * self.grid),
            self.frames,
            self.seconds,
            self.measured_at,
            self.reused_from
                .as_ref()
                .map_or(String::new(), |f| format!(" (reused from {f})")),
            m.fixed_ms,
            1e3 * m.per_triangle_ms,
            1e6 * m.per_triangle_varying_ms,
            1e6 * m.per_edge_pixel_ms,
            m.pixel_ms,
            m.depth_test_ms
        );
        let pixels = f64::from(self.width) * f64::from(self.height);
        for kind in Kind::ALL {
            s += &format!(
                "| {} | {:.4} | {:.3} |\n",
                kind.name(),
                m.cost(kind),
                m.cost(kind) * 1e6 / pixels
            );
        }
        s += &format!(
            "\nA branch that no lane of a SIMD batch takes costs {:.2} of its straight-line work (0: the device jumps over it; 1: it runs it with the lanes masked off)\n",
            m.untaken_share
        );
        let retimed = self.points.iter().filter(|p| p.batches > 1).count();
        s += &format!(
            "\ndevice: {} (a monitor frame after every point's frames; ms median: of the point's frames in the main state, of its fastest build there)\n\n{retimed} point(s) that had fewer than {MIN_STATE_FRAMES} frames, from fewer than {MIN_STATE_ROUNDS} rounds, in the fastest state holding {:.0} % of the monitor frames or more, or that a fit missed by more than {:.0} % while no two of their builds agreed within {:.0} %, timed in up to {RETIME_BATCHES} more batches of rounds, one at a time while so\n",
            self.states.describe(),
            100.0 * STATE_MODEL_SHARE,
            100.0 * RETIME_ERROR,
            100.0 * BUILD_AGREEMENT
        );
        for m in &self.state_models {
            s += &format!(
                "\nstate {} (monitor frame {:.3} ms){}: largest model error {:.1} % ({}); fixed {:.3} ms, empty shader {:.3} ms per screen, ns per unit per lane: {}\n",
                m.state,
                self.states.monitor_ms[m.state],
                if m.state == self.states.main_state {
                    ", the main model (the table below)"
                } else {
                    ""
                },
                100.0 * m.worst_relative_error,
                m.worst_point,
                m.model.fixed_ms,
                m.model.pixel_ms,
                Kind::ALL
                    .iter()
                    .map(|&k| format!("{} {:.3}", k.name(), m.model.cost(k) * 1e6 / pixels))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        s += "\n| point | count | lanes per pixel | triangles | edge pixels | depth | batches | frames in state / timed | ms median | model ms | model / measured |\n|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|\n";
        for p in &self.points {
            s += &format!(
                "| {} | {} | {:.2} | {} | {:.0} | {} | {} | {} / {} | {:.3} | {:.3} | {:.3} |\n",
                p.label(),
                p.count,
                p.coverage,
                p.triangles,
                p.edge_pixels,
                if p.depth_test { "on" } else { "off" },
                p.batches,
                p.state_frames,
                p.frames,
                p.ms_median,
                p.model_ms,
                p.model_ms / p.ms_median
            );
        }
        s += &format!(
            "\nlargest model error over the points: {:.1} %\n",
            100.0 * self.worst_relative_error()
        );
        s
    }
}
