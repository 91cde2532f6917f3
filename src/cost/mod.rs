//! The device cost model (DESIGN §5 `src/cost/`): what a fragment shader does per pixel, by
//! [`Kind`] ([`CostCounts`]), read off its SPIR-V ([`spirv`]) and the images it binds; how a
//! shader whose work depends on its data is counted ([`CountPlan`]); and the model that
//! prices the counts ([`CostModel`]), fitted on each device by the probe (`crate::probe`).
//! Building a technique never counts: the bench and the probe ask for a technique's counts
//! (`technique::cost::counts`).
//!
//! **Model.** t = fixed + T·(c_T + n_V c_TV) + E·c_E + f · (p + Σ_k n_k c_k), T the
//! triangles drawn and c_T the cost of one (setup, vertex shading), c_TV that of each of the
//! n_V interpolated floats the fragment shader reads (the vertex stage writes it, the
//! triangle's set-up computes its plane; on lavapipe 2.2 ns in the faster state, 6.3 in the
//! slower, where pcaMv over 115k triangles ran 1.14× the model without it), E the length
//! of their edges on the screen in pixels (`scene::screen_triangles`, clipped to the view,
//! hidden ones included: the rasterizer walks them) and c_E the cost of a pixel of edge
//! (the partly covered blocks along it), f the device lanes a frame of the mesh keeps busy
//! per screen pixel (`SceneGpu::shading_load`: by additive blending each fragment
//! adds its share of the subgroup it ran in, so overdraw — hidden surfaces drawn before
//! their occluders — counts, and so do the idle lanes of SIMD batches that small triangles
//! cover in part: on lavapipe 1.01 lanes per fragment over screen-sized triangles, 1.27,
//! 1.30 and 1.54 over the 125, 55 and 31-pixel grids), p the per-lane cost of the empty
//! shader with the depth test over a screen (the depth test's own part, p − p_off, is
//! reported), n_k a shader's count of kind k per pixel and c_k the cost of one per lane
//! over a screen. The lookup counts of a probe point are what it was generated with; its
//! float ops, uniform and varying reads are read off its SPIR-V ([`spirv`]),
//! exactly as a technique's are, so probe and techniques are counted alike (a technique
//! whose work depends on its data — the clustered decodes — by the shares of its paths,
//! [`CountPlan`]). p and the c_k are fitted jointly with fixed, c_T, c_E
//! and the depth test's part of p, none below zero, over every point — among them a frame
//! that draws one zero-area triangle (fixed), the empty shader over half the screen (half
//! the triangles, half the fragments) and over the screen with the depth test off — by a
//! **minimax** fit: the costs that make the largest relative error over the points least
//! (a linear program, `probe::fit::chebyshev_fit`), as the model is judged by its worst point. A
//! least-squares fit (weighted by 1/t) leaves 7.6–9.5 % on the same points where this
//! leaves 6.1–8.0 %.
//!
//! **How lavapipe runs the clustered decodes** (each measured by taking one thing out of
//! cluster.frag): an unfiltered texel fetch costs 0.70 ns per lane where a
//! bilinear lookup costs 1.79 ([`Kind::TexelFetch`], the taps); a branch that no lane of a
//! SIMD batch takes still costs its straight-line code, run with the lanes masked off, while
//! a loop that no lane enters is skipped (vq256: 14.8 ms with the boundary branch taken out,
//! 28.0 with it there and never taken) — [`CostModel::untaken_share`], fitted with the
//! costs to points whose reads sit in a branch no lane takes as well as to the rest (1.00
//! here; a GPU that jumps over coherent branches would give 0); and reads in a kept loop cost a loop set-up besides (≈ 4 ns per
//! lane, [`Kind::Loop`]: the indexed-read points read in such a loop, as the decode does;
//! straight-line they fitted 1.15× at 144 reads and 0.85× at 18).
//!
//! **What a CPU rasterizer pays that a GPU does not** (each its own kind, so each device's
//! probe prices it): transcendentals ([`Kind::Transcendental`], polynomials on lavapipe:
//! 0.048 ns per lane against 0.006 for a float op, on a 2-vCPU EPYC), integer divides by a
//! computed divisor ([`Kind::IntegerDivide`], lane by lane: 0.84 ns), private arrays read at
//! a computed index ([`Kind::IndexedPrivateRead`], gathered from the stack: 0.19 ns) and
//! block-compressed lookups ([`Kind::Bc6hArray`], [`Kind::Bc7Array`], [`Kind::Bc4Array`],
//! decoded in software at every fetch: 179, 124 and 3.5 ns against 2.5 for an RGBA16F array
//! lookup).
//!
//! **Limits.** The per-triangle and per-edge costs are the probe's: screen-filling grids
//! with the shared vertex shader; a vertex shader's own work beyond the varyings it writes
//! (pcaMv's copies its weights) is not priced. On lavapipe a term in
//! triangles alone could not hold the grids (from screen-sized triangles to 125-pixel ones
//! cost a step of ≈ 2.5 ms per screen, further steps less: ≈ T^0.4); with the edges it
//! does, and the fit puts nearly all of it there (4–8 ns per edge pixel, the per-triangle
//! cost near zero — held at zero where the fit would put it below, as T and E of the grids
//! grow together). Counts are static: branches count both sides unless a
//! [`CountPlan`] weights them; loops that a driver may
//! unroll (no `[[dont_unroll]]`: the SH evaluations' in a few shaders) are counted once,
//! as written. Uniform reads at a
//! per-pixel index are their own kind; the probe's index is coherent over a band of the
//! screen, as a cluster id over a chart. Caches: every probe lookup reads its own texture at
//! neighbouring coordinates, as the techniques' texel and table fetches do, but a scene's
//! access pattern (table lookups scattered by the normal map) may hit worse. Register
//! pressure is not priced: the probe's chains keep little live, and a shader that keeps
//! much (cluster.frag fully unrolled, 36 floats of SH sums live) ran 2–3× its model.

pub mod plan;
pub mod spirv;

use serde::{Deserialize, Serialize};

pub use plan::{CountPlan, CountVariant};
use spirv::OpCounts;

/// How many kinds the model prices.
pub const KINDS: usize = 19;

/// The operation kinds the model prices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// Bilinear 2D lookup, no MIP chain (dx9's per-texel data).
    Bilinear2d,
    /// Trilinear lookup through a MIP chain (material textures).
    Trilinear2d,
    /// Bilinear 2D-array lookup (dx10's per-texel data).
    Array2d,
    /// Cube-array lookup (dx10's normal-indexed tables).
    CubeArray,
    /// 2D lookup at coordinates computed from a previous lookup (dx9's tables).
    Dependent2d,
    /// Scalar float operation (a fused multiply-add counts once).
    FloatOp,
    /// Interpolated float read from the vertex stage.
    Varying,
    /// vec4 read from a uniform block at a constant index.
    UniformRead,
    /// vec4 read from a uniform block at an index computed per pixel (a cluster's block).
    IndexedUniformRead,
    /// Unfiltered 2D texel fetch (`texelFetch`), four per texture at the texels of a
    /// bilinear footprint (the clustered techniques' taps).
    TexelFetch,
    /// A loop entered (set-up and exit of a loop the drawn shader keeps, `[[dont_unroll]]`,
    /// its body counted per iteration apart); priced by the indexed-read points, which read
    /// in such a loop.
    Loop,
    /// Trilinear lookup through a MIP chain of RGBA32F texels (the NDF moment maps): four
    /// times the bytes of [`Kind::Trilinear2d`]'s RGBA8 (lavapipe on a 2-vCPU Xeon: the
    /// NDF rows ran 1.23× a model that priced them as RGBA8).
    TrilinearWide,
    /// Trilinear lookup through a MIP chain of sRGB RGBA8 texels (the albedo, which every
    /// technique reads): each texel decoded to linear before it is filtered (lavapipe on a
    /// 2-vCPU Xeon: the house's albedo lookup 7.5 ms a frame where its UNORM normal map's
    /// took 5.9, and every row ran 1.05–1.20× a model that priced the albedo as UNORM).
    TrilinearSrgb,
    /// Transcendental function, per component (`exp`, `exp2`, `log`, `log2`, `pow`, `sin`,
    /// `cos`, `tan` and their inverses): a polynomial of many float ops where the device has
    /// no special-function unit (lavapipe), one instruction where it has (GPUs). The SG
    /// lobes' `exp`.
    Transcendental,
    /// Float read from a private array at an index computed per pixel (Ambient Dice's
    /// stored values at a vertex's offset): a register on GPUs where the index is uniform,
    /// else scratch memory; lavapipe gathers each lane's element from the stack.
    IndexedPrivateRead,
    /// Integer division or remainder by a divisor that is not a compile-time constant
    /// (Ambient Dice's atlas tile on dx9: a group's column and row among the atlas' columns,
    /// a uniform); a constant divisor is a multiply and shift, not counted. No SIMD unit
    /// divides integers: a CPU divides the lanes one by one. The probe's divisor varies per
    /// pixel, so a device that hoists a uniform divisor's set-up pays less than it prices.
    IntegerDivide,
    /// Bilinear 2D-array lookup of a BC6H layer (dx11's norms): decoded in the texture unit
    /// on GPUs, in software at every fetch on lavapipe.
    Bc6hArray,
    /// Bilinear 2D-array lookup of a BC7 layer (dx11's ratios).
    Bc7Array,
    /// Bilinear 2D-array lookup of a BC4 layer (dx11's single values).
    Bc4Array,
}

impl Kind {
    pub const ALL: [Kind; KINDS] = [
        Kind::Bilinear2d,
        Kind::Trilinear2d,
        Kind::Array2d,
        Kind::CubeArray,
        Kind::Dependent2d,
        Kind::FloatOp,
        Kind::Varying,
        Kind::UniformRead,
        Kind::IndexedUniformRead,
        Kind::TexelFetch,
        Kind::Loop,
        Kind::TrilinearWide,
        Kind::TrilinearSrgb,
        Kind::Transcendental,
        Kind::IndexedPrivateRead,
        Kind::IntegerDivide,
        Kind::Bc6hArray,
        Kind::Bc7Array,
        Kind::Bc4Array,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Kind::Bilinear2d => "bilinear 2D lookup",
            Kind::Trilinear2d => "trilinear lookup",
            Kind::Array2d => "2D-array lookup",
            Kind::CubeArray => "cube-array lookup",
            Kind::Dependent2d => "dependent 2D lookup",
            Kind::FloatOp => "float op",
            Kind::Varying => "varying float",
            Kind::UniformRead => "uniform vec4 read",
            Kind::IndexedUniformRead => "indexed uniform vec4 read",
            Kind::TexelFetch => "texel fetch",
            Kind::Loop => "loop entered",
            Kind::TrilinearWide => "trilinear RGBA32F lookup",
            Kind::TrilinearSrgb => "trilinear sRGB lookup",
            Kind::Transcendental => "transcendental",
            Kind::IndexedPrivateRead => "indexed private float read",
            Kind::IntegerDivide => "integer divide",
            Kind::Bc6hArray => "BC6H array lookup",
            Kind::Bc7Array => "BC7 array lookup",
            Kind::Bc4Array => "BC4 array lookup",
        }
    }

    /// Whether this kind is a texture lookup (the rest are shader operations and reads).
    pub fn is_lookup(self) -> bool {
        !matches!(
            self,
            Kind::FloatOp
                | Kind::Varying
                | Kind::UniformRead
                | Kind::IndexedUniformRead
                | Kind::Loop
                | Kind::Transcendental
                | Kind::IndexedPrivateRead
                | Kind::IntegerDivide
        )
    }

    /// The block-compressed format a lookup of this kind reads, for the BC kinds.
    pub fn block_format(self) -> Option<ash::vk::Format> {
        match self {
            Kind::Bc6hArray => Some(ash::vk::Format::BC6H_UFLOAT_BLOCK),
            Kind::Bc7Array => Some(ash::vk::Format::BC7_UNORM_BLOCK),
            Kind::Bc4Array => Some(ash::vk::Format::BC4_UNORM_BLOCK),
            _ => None,
        }
    }

    /// The BC kind of a 2D-array lookup of `format`, where it is one of them.
    pub fn of_block_format(format: ash::vk::Format) -> Option<Kind> {
        Kind::ALL
            .into_iter()
            .find(|k| k.block_format() == Some(format))
    }

    pub(crate) fn index(self) -> usize {
        Kind::ALL.iter().position(|&k| k == self).unwrap_or(0)
    }
}

/// Per-pixel counts of a shader, by [`Kind`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CostCounts(pub [f64; KINDS]);

impl CostCounts {
    /// The counts of a shader with `lookups` (kind, count) and the SPIR-V counts `ops`.
    pub fn new(lookups: &[(Kind, u32)], ops: &OpCounts) -> Self {
        let mut c = [0.0; KINDS];
        for &(kind, n) in lookups {
            c[kind.index()] += f64::from(n);
        }
        c[Kind::FloatOp.index()] += f64::from(ops.float_ops);
        c[Kind::Varying.index()] += f64::from(ops.varying_reads);
        c[Kind::UniformRead.index()] += f64::from(ops.uniform_reads);
        c[Kind::IndexedUniformRead.index()] += f64::from(ops.indexed_uniform_reads);
        c[Kind::Loop.index()] += f64::from(ops.kept_loops);
        c[Kind::Transcendental.index()] += f64::from(ops.transcendentals);
        c[Kind::IndexedPrivateRead.index()] += f64::from(ops.indexed_private_reads);
        c[Kind::IntegerDivide.index()] += f64::from(ops.integer_divides);
        CostCounts(c)
    }

    /// Σ share · counts: the counts of a shader whose pixels run different paths.
    pub fn shared(parts: impl IntoIterator<Item = (f64, CostCounts)>) -> Self {
        let mut c = [0.0; KINDS];
        for (share, counts) in parts {
            for (sum, n) in c.iter_mut().zip(counts.0) {
                *sum += share * n;
            }
        }
        CostCounts(c)
    }

    pub fn get(&self, kind: Kind) -> f64 {
        self.0[kind.index()]
    }

    /// `self − other`, none below zero.
    pub fn less(&self, other: &CostCounts) -> CostCounts {
        CostCounts(std::array::from_fn(|k| (self.0[k] - other.0[k]).max(0.0)))
    }
}

/// The fitted model (module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostModel {
    /// Per frame, whatever is drawn (clear, submission, timestamps), ms.
    pub fixed_ms: f64,
    /// The empty shader with the depth test over the whole screen, ms.
    pub pixel_ms: f64,
    /// Of which the depth test, ms (empty shader, depth on − off).
    pub depth_test_ms: f64,
    /// Per triangle drawn (setup, rasterization, vertex shading), ms.
    pub per_triangle_ms: f64,
    /// Per pixel of triangle edge on the screen (the rasterizer's partly covered blocks), ms.
    pub per_edge_pixel_ms: f64,
    /// Per triangle per interpolated float the fragment shader reads (the vertex stage's
    /// output and the triangle's set-up of its plane equation), ms.
    pub per_triangle_varying_ms: f64,
    /// ms per unit of each kind per pixel over the whole screen, in [`Kind::ALL`] order.
    pub per_unit_ms: [f64; KINDS],
    /// The share of a branch's work that the device runs where no lane of a SIMD batch
    /// takes the branch: 0 where it jumps over it (GPUs, on coherent branches), 1 where it
    /// runs the branch's straight-line code with the lanes masked off (lavapipe; a loop no
    /// lane enters it skips). Fitted with the costs, on a grid 0.05 apart ([`fit`]).
    pub untaken_share: f64,
}

impl CostModel {
    /// Predicted frame time of a shader with `counts` keeping `coverage` lanes busy per
    /// screen pixel over a mesh of `triangles` whose edges are `edge_pixels` long on the
    /// screen.
    pub fn predict(
        &self,
        counts: &CostCounts,
        coverage: f64,
        triangles: u32,
        edge_pixels: f64,
    ) -> f64 {
        let per_pixel: f64 = counts
            .0
            .iter()
            .zip(&self.per_unit_ms)
            .map(|(n, c)| n * c)
            .sum();
        let varyings = counts.0[Kind::Varying.index()];
        self.fixed_ms
            + f64::from(triangles)
                * (self.per_triangle_ms + varyings * self.per_triangle_varying_ms)
            + edge_pixels * self.per_edge_pixel_ms
            + coverage * (self.pixel_ms + per_pixel)
    }

    pub fn cost(&self, kind: Kind) -> f64 {
        self.per_unit_ms[kind.index()]
    }

    /// The counts this device runs of a shader that does `taken` and skips `untaken` (the
    /// straight-line work of branches no lane of a batch takes): `taken + untaken_share ·
    /// untaken`.
    pub fn with_untaken(&self, taken: &CostCounts, untaken: &CostCounts) -> CostCounts {
        CostCounts::shared([(1.0, *taken), (self.untaken_share, *untaken)])
    }
}
