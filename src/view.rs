//! `shvis view`: a window that renders the scene with any technique × path,
//! switched by keys, an orbit camera, and the sun — the environment turned about +Y — moved
//! by keys or animated, with the dynamic-lighting machinery of `shvis relight`: the
//! technique is built with two lighting sets (`technique::build_dynamic`), a worker thread
//! rebuilds the lighting data for the current sun angle at most every K frames, and the
//! finished data is swapped in without waiting (`TechniqueGpu::update_lighting`), so a
//! rebuild never stalls a frame. The overlay names the technique and path, the GPU ms of
//! the frame from its timestamps, the frame rate and the sun angle.
//!
//! Each frame is rendered into the technique's offscreen target as `shvis render` does,
//! read back, encoded to sRGB with the exposure (`report::image::to_srgb8`, the PNG
//! writer's), the overlay drawn on the host (plotters' text on the bitmap, with the plots'
//! font — no GUI toolkit: the frame is already on the host, and a text overlay is all the
//! viewer needs), and copied into the swapchain image (`gpu::swapchain`). Hence a screenshot
//! outside the overlay equals `shvis render` of the same view byte for byte, which is what
//! the viewer test checks.
//!
//! Keys: Tab / N next technique, B previous, P the next path (dx9 → dx10 → dx11), ← / → turn
//! the sun by 15°, Space start/stop the sun's animation, R reset camera and sun, Esc / Q
//! quit. Drag with the left button to orbit the camera, with the right one to turn the sun;
//! wheel to move closer.

pub mod summary;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

use crate::env::schedule::LightingSchedule;
use crate::gpu::TimingStats;
use crate::gpu::swapchain::{Presenter, surface_extensions};
use crate::gpu::{Context, ContextDesc};
use crate::prepare::Prepared;
use crate::render::{FrameSettings, SceneGpu};
use crate::report::image::to_srgb8;
use crate::scene::Camera;
use crate::sh::Order;
use crate::sh::zonal::irradiance_from_radiance;
use crate::technique::{self, HwPath, LightingData, LightingRecipe, Technique, TechniqueGpu};

/// The overlay's box, pixels from the top-left corner: (width, height).
pub const OVERLAY_BOX: (u32, u32) = (420, 96);

/// Sun steps of the schedule: tenths of a degree.
const SUN_STEPS_PER_TURN: u32 = 3600;

/// What `shvis view` shows and how long it runs.
#[derive(Clone, Debug)]
pub struct ViewSettings {
    /// The techniques Tab cycles through; the first is shown first.
    pub techniques: Vec<Technique>,
    pub path: HwPath,
    pub width: u32,
    pub height: u32,
    pub exposure: f32,
    /// Stop after this many frames (the test); `None`: until the window is closed.
    pub frames: Option<u32>,
    /// Switch to the next technique at this frame (the test's one switch).
    pub switch_at: Option<u32>,
    /// Write the last presented frame (read back from the swapchain) here.
    pub screenshot: Option<PathBuf>,
    /// Rebuild the lighting data at most every this many frames.
    pub every: u32,
    /// Start with the sun animating, at this many degrees per frame.
    pub animate: Option<f64>,
    /// Draw the overlay.
    pub overlay: bool,
    pub validate: bool,
    pub device: Option<String>,
}

/// Errors of the viewer: one line each.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error(
        "cannot open a window: {0} (no display? set DISPLAY, or run under `xvfb-run -a shvis view …`)"
    )]
    Display(String),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error(transparent)]
    Technique(#[from] crate::technique::TechniqueError),
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    #[error("{0}")]
    Other(String),
}

/// What a run measured (printed by the command).
#[derive(Clone, Debug, Default)]
pub struct ViewReport {
    pub device: String,
    pub present_mode: String,
    /// Per technique × path shown: its label, frames, median frame wall ms (render,
    /// readback, overlay, present; `None` when no frame was timed whole) and median GPU ms.
    pub shown: Vec<(String, usize, Option<f64>, Option<f64>)>,
    /// Lighting rebuilds swapped in, their CPU build ms (median), and the longest frame
    /// that swapped one in against the median frame of the run (the stall test).
    pub rebuilds: usize,
    pub rebuild_cpu_ms: Option<f64>,
    pub longest_swap_frame_ms: Option<f64>,
    pub median_frame_ms: Option<f64>,
    pub longest_frame_ms: Option<f64>,
    pub validation: (u32, u32),
}

/// Opens the window and runs until it is closed or `settings.frames` are shown.
///
/// # Errors
/// No display, no device that can present, a technique that cannot be built, a failing
/// frame or screenshot.
pub fn run(prepared: &Prepared, settings: &ViewSettings) -> Result<ViewReport, ViewError> {
    if settings.techniques.is_empty() {
        return Err(ViewError::Other("no technique to show".into()));
    }
    let event_loop = EventLoop::new().map_err(|e| ViewError::Display(winit_message(&e)))?;
    let mut app = App {
        prepared,
        settings,
        state: None,
        error: None,
        report: ViewReport::default(),
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewError::Display(e.to_string()))?;
    if let Some(e) = app.error {
        return Err(e);
    }
    Ok(app.report)
}

/// winit's error text without the source location it puts in front ("os error at
/// …/mod.rs:765: neither … is set").
fn winit_message(e: &impl std::fmt::Display) -> String {
    let text = e.to_string();
    match text.rsplit_once(".rs:") {
        Some((_, tail)) => tail.split_once(": ").map_or(tail, |(_, m)| m).to_string(),
        None => text,
    }
}

struct App<'a> {
    prepared: &'a Prepared,
    settings: &'a ViewSettings,
    state: Option<State>,
    error: Option<ViewError>,
    report: ViewReport,
}

/// A lighting rebuild on the worker: the sun step it builds and its result with CPU ms.
type Building = (
    u32,
    std::thread::JoinHandle<Result<(LightingData, f64), String>>,
);

struct State {
    // Drop order: the technique and scene before the presenter, the presenter before the
    // window, the context last (it is shared).
    tech: TechniqueGpu,
    recipe: Option<Arc<LightingRecipe>>,
    scene: SceneGpu,
    presenter: Presenter,
    window: Arc<Window>,
    ctx: Arc<Context>,
    schedule: Arc<LightingSchedule>,
    technique_index: usize,
    path: HwPath,
    home: Camera,
    yaw: f32,
    pitch: f32,
    distance_scale: f32,
    dragging: Option<(f64, f64)>,
    /// Right-button drag: the cursor x where it last turned the sun.
    sun_drag: Option<f64>,
    cursor: (f64, f64),
    /// The sun angle wanted (schedule steps) and the one the front lighting set holds.
    sun: f64,
    sun_built: u32,
    animate: Option<f64>,
    building: Option<Building>,
    frame: u32,
    since_switch: Vec<f64>,
    gpu_since_switch: Vec<f64>,
    frame_ms: Vec<f64>,
    swap_frames_ms: Vec<f64>,
    rebuild_cpu_ms: Vec<f64>,
    last: Instant,
    fps: f64,
}

impl App<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewError) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<State, ViewError> {
        let s = self.settings;
        let attributes = Window::default_attributes()
            .with_title("shvis view")
            .with_inner_size(winit::dpi::PhysicalSize::new(s.width, s.height))
            .with_resizable(false);
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| ViewError::Display(e.to_string()))?,
        );
        let display = window
            .display_handle()
            .map_err(|e| ViewError::Display(e.to_string()))?
            .as_raw();
        let handle = window
            .window_handle()
            .map_err(|e| ViewError::Display(e.to_string()))?
            .as_raw();
        let ctx = Context::new(&ContextDesc {
            validate: s.validate,
            device: s.device.clone(),
            surface_extensions: surface_extensions(display)?,
        })?;
        log::info!("device: {}", ctx.device_name());
        let presenter = Presenter::new(&ctx, display, handle, s.width, s.height)?;
        let (width, height) = presenter.extent();
        let scene = SceneGpu::new(
            &ctx,
            &self.prepared.scene,
            &FrameSettings {
                width,
                height,
                ..FrameSettings::default()
            },
        )?;
        let n = self.prepared.radiance_sh.len();
        let order =
            Order::new((n as f64).sqrt() as u32).map_err(|e| ViewError::Other(e.to_string()))?;
        let schedule = Arc::new(LightingSchedule::rotating(
            order,
            self.prepared.radiance_sh.clone(),
            1.0,
            SUN_STEPS_PER_TURN,
        ));
        let (tech, recipe) = build(
            &ctx,
            &scene,
            self.prepared,
            &schedule,
            s.techniques[0],
            s.path,
            0,
        )?;
        let camera = self.prepared.scene.camera;
        self.report.device = ctx.device_name().to_string();
        self.report.present_mode = format!("{:?}", presenter.present_mode());
        Ok(State {
            tech,
            recipe,
            scene,
            presenter,
            window,
            ctx,
            schedule,
            technique_index: 0,
            path: s.path,
            home: camera,
            yaw: 0.0,
            pitch: 0.0,
            distance_scale: 1.0,
            dragging: None,
            sun_drag: None,
            cursor: (0.0, 0.0),
            sun: 0.0,
            sun_built: 0,
            animate: s.animate,
            building: None,
            frame: 0,
            since_switch: Vec::new(),
            gpu_since_switch: Vec::new(),
            frame_ms: Vec::new(),
            swap_frames_ms: Vec::new(),
            rebuild_cpu_ms: Vec::new(),
            last: Instant::now(),
            fps: 0.0,
        })
    }

    /// One frame: lighting swap or rebuild, render, overlay, present; the run's end.
    fn draw(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewError> {
        let s = self.settings;
        let Some(st) = self.state.as_mut() else {
            return Ok(());
        };
        if s.switch_at == Some(st.frame) {
            let next = (st.technique_index + 1) % s.techniques.len();
            switch(st, self.prepared, &mut self.report, s, next, st.path)?;
        }
        if let Some(step) = st.animate {
            st.sun = (st.sun + step * 10.0).rem_euclid(f64::from(SUN_STEPS_PER_TURN));
        }
        // A finished rebuild is swapped in (this frame draws it), and a new one started
        // when the sun has moved and K frames have passed.
        let mut swapped = false;
        if st.building.as_ref().is_some_and(|(_, h)| h.is_finished()) {
            let (step, handle) = st.building.take().expect("checked above");
            let (data, cpu_ms) = handle
                .join()
                .map_err(|_| ViewError::Other("the lighting rebuild panicked".into()))?
                .map_err(ViewError::Other)?;
            st.tech.update_lighting(&data)?;
            st.sun_built = step;
            st.rebuild_cpu_ms.push(cpu_ms);
            swapped = true;
        }
        let wanted = st.sun.round() as u32 % SUN_STEPS_PER_TURN;
        if let Some(recipe) = &st.recipe
            && st.building.is_none()
            && wanted != st.sun_built
            && st.frame % s.every.max(1) == 0
        {
            let (recipe, schedule) = (recipe.clone(), st.schedule.clone());
            st.building = Some((
                wanted,
                std::thread::spawn(move || {
                    let start = Instant::now();
                    let radiance = schedule.at(wanted);
                    let irradiance = irradiance_from_radiance(&radiance[..9], Order::THREE);
                    recipe
                        .build(&radiance, &irradiance)
                        .map(|d| (d, start.elapsed().as_secs_f64() * 1e3))
                        .map_err(|e| e.to_string())
                }),
            ));
        }
        let frame = st.tech.render(&st.scene, 0, 1)?;
        let gpu_ms = frame.ms.first().copied();
        let mut rgb = to_srgb8(&frame, s.exposure);
        let (w, h) = st.presenter.extent();
        if s.overlay {
            let lines = [
                st.tech.label(),
                format!(
                    "GPU {}  ·  {:.1} frames/s",
                    gpu_ms.map_or("— (no timestamps)".into(), |m| format!("{m:.2} ms")),
                    st.fps
                ),
                format!(
                    "sun {:.0}°{}{}",
                    f64::from(st.sun_built) / 10.0,
                    if st.animate.is_some() {
                        "  (animating)"
                    } else {
                        ""
                    },
                    if st.recipe.is_none() {
                        "  (lighting baked in)"
                    } else {
                        ""
                    }
                ),
                "Tab technique · P path · ←/→ sun · Space animate · drag orbit".to_string(),
            ];
            draw_overlay(&mut rgb, w, h, &lines).map_err(ViewError::Other)?;
        }
        let last_frame = s.frames.is_some_and(|n| st.frame + 1 >= n);
        let shot = st
            .presenter
            .present(&rgb, last_frame && s.screenshot.is_some())?;
        if let (Some(pixels), Some(path)) = (shot, &s.screenshot) {
            let png =
                crate::report::image::encode_png(&pixels, w, h, image::ExtendedColorType::Rgb8)
                    .map_err(|e| ViewError::Other(format!("{}: {e}", path.display())))?;
            crate::report::image::write_file(path, &png)?;
            log::info!("wrote {}", path.display());
        }
        let now = Instant::now();
        let ms = now.duration_since(st.last).as_secs_f64() * 1e3;
        st.last = now;
        if st.frame > 0 {
            // The first frame's time includes the window's set-up.
            st.frame_ms.push(ms);
            st.since_switch.push(ms);
            if swapped {
                st.swap_frames_ms.push(ms);
            }
        }
        if let Some(g) = gpu_ms {
            st.gpu_since_switch.push(g);
        }
        st.fps = 1e3 / ms.max(1e-3);
        st.window.set_title(&format!(
            "shvis view — {} — {:.1} fps",
            st.tech.label(),
            st.fps
        ));
        st.frame += 1;
        if last_frame {
            event_loop.exit();
        }
        Ok(())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) -> Result<(), ViewError> {
        let s = self.settings;
        let Some(st) = self.state.as_mut() else {
            return Ok(());
        };
        let n = s.techniques.len();
        let letter = match key {
            Key::Character(c) => c.to_ascii_lowercase(),
            _ => String::new(),
        };
        match (key, letter.as_str()) {
            (Key::Named(NamedKey::Escape), _) | (_, "q") => event_loop.exit(),
            (Key::Named(NamedKey::Tab), _) | (_, "n") => {
                let next = (st.technique_index + 1) % n;
                switch(st, self.prepared, &mut self.report, s, next, st.path)?;
            }
            (_, "b") => {
                let previous = (st.technique_index + n - 1) % n;
                switch(st, self.prepared, &mut self.report, s, previous, st.path)?;
            }
            (_, "p") => {
                let path = match st.path {
                    HwPath::Dx9 => HwPath::Dx10,
                    HwPath::Dx10 => HwPath::Dx11,
                    HwPath::Dx11 => HwPath::Dx9,
                };
                switch(
                    st,
                    self.prepared,
                    &mut self.report,
                    s,
                    st.technique_index,
                    path,
                )?;
            }
            (Key::Named(NamedKey::ArrowLeft), _) => st.sun = (st.sun - 150.0).rem_euclid(3600.0),
            (Key::Named(NamedKey::ArrowRight), _) => st.sun = (st.sun + 150.0).rem_euclid(3600.0),
            (Key::Named(NamedKey::Space), _) => {
                st.animate = match st.animate {
                    Some(_) => None,
                    None => Some(s.animate.unwrap_or(1.0)),
                };
            }
            (_, "r") => {
                st.yaw = 0.0;
                st.pitch = 0.0;
                st.distance_scale = 1.0;
                st.sun = 0.0;
                orbit(st)?;
            }
            _ => {}
        }
        Ok(())
    }
}

/// Builds `technique` on `path` for the sun at `step`: with two lighting sets and its
/// recipe when its lighting can change, else as baked.
fn build(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    prepared: &Prepared,
    schedule: &LightingSchedule,
    technique: Technique,
    path: HwPath,
    step: u32,
) -> Result<(TechniqueGpu, Option<Arc<LightingRecipe>>), ViewError> {
    let radiance = schedule.at(step);
    let irradiance = irradiance_from_radiance(&radiance[..9], Order::THREE);
    let inputs = technique::Inputs {
        radiance_sh: &radiance,
        irradiance_sh: &irradiance,
        ..prepared.inputs()
    };
    if technique.dynamic_lighting() {
        let (tech, recipe) = technique::build_dynamic(ctx, scene, technique, path, &inputs)?;
        Ok((tech, Some(Arc::new(recipe))))
    } else {
        Ok((
            technique::build(ctx, scene, technique, path, &inputs)?,
            None,
        ))
    }
}

/// Shows technique `index` on `path`, recording what the previous one measured.
fn switch(
    st: &mut State,
    prepared: &Prepared,
    report: &mut ViewReport,
    s: &ViewSettings,
    index: usize,
    path: HwPath,
) -> Result<(), ViewError> {
    record_shown(st, report);
    if let Some((_, handle)) = st.building.take() {
        let _ = handle.join();
    }
    // A technique without a form on the path (dx11's refusals) is shown on dx10.
    let technique = s.techniques[index];
    let path = match technique.form_on(path) {
        Err(why) => {
            log::info!("{technique}.{path}: {why}; showing dx10");
            HwPath::Dx10
        }
        Ok(_) => path,
    };
    let step = st.sun.round() as u32 % SUN_STEPS_PER_TURN;
    let (tech, recipe) = build(
        &st.ctx,
        &st.scene,
        prepared,
        &st.schedule,
        s.techniques[index],
        path,
        step,
    )?;
    st.tech = tech;
    st.recipe = recipe;
    st.sun_built = step;
    st.technique_index = index;
    st.path = path;
    log::info!("showing {}", st.tech.label());
    Ok(())
}

fn record_shown(st: &mut State, report: &mut ViewReport) {
    if st.since_switch.is_empty() && st.gpu_since_switch.is_empty() {
        return;
    }
    let wall = TimingStats::from_ms(&st.since_switch).map(|t| t.ms_median);
    let gpu = TimingStats::from_ms(&st.gpu_since_switch).map(|t| t.ms_median);
    report
        .shown
        .push((st.tech.label(), st.since_switch.len(), wall, gpu));
    st.since_switch.clear();
    st.gpu_since_switch.clear();
}

/// Moves the camera to the orbit's yaw, pitch and distance about the home target.
fn orbit(st: &mut State) -> Result<(), ViewError> {
    let home = st.home;
    let offset = home.position - home.target;
    let rotation = glam::Quat::from_rotation_y(st.yaw)
        * glam::Quat::from_axis_angle(
            offset.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X),
            st.pitch,
        );
    st.scene.set_camera(&Camera {
        position: home.target + rotation * offset * st.distance_scale,
        ..home
    })?;
    Ok(())
}

/// The overlay: a translucent box in the top-left corner ([`OVERLAY_BOX`]) with `lines`.
fn draw_overlay(rgb: &mut [u8], width: u32, height: u32, lines: &[String]) -> Result<(), String> {
    use plotters::prelude::*;
    crate::report::plot::register_plot_font()?;
    let root = BitMapBackend::with_buffer(rgb, (width, height)).into_drawing_area();
    let (bw, bh) = (
        OVERLAY_BOX.0.min(width) as i32,
        OVERLAY_BOX.1.min(height) as i32,
    );
    root.draw(&Rectangle::new(
        [(0, 0), (bw, bh)],
        RGBColor(0, 0, 0).mix(0.6).filled(),
    ))
    .map_err(|e| e.to_string())?;
    let font = ("sans-serif", 15).into_font().color(&WHITE);
    for (i, line) in lines.iter().enumerate() {
        root.draw(&Text::new(
            line.as_str(),
            (8, 6 + 22 * i as i32),
            font.clone(),
        ))
        .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.state.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(state) => {
                state.window.request_redraw();
                self.state = Some(state);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let result = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::RedrawRequested => self.draw(event_loop),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(event_loop, &event.logical_key)
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => {
                if let Some(st) = self.state.as_mut() {
                    st.dragging = (state == ElementState::Pressed).then_some(st.cursor);
                }
                Ok(())
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Right,
                ..
            } => {
                if let Some(st) = self.state.as_mut() {
                    st.sun_drag = (state == ElementState::Pressed).then_some(st.cursor.0);
                }
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => match self.state.as_mut() {
                Some(st) => {
                    st.cursor = (position.x, position.y);
                    if let Some(x0) = st.sun_drag {
                        // Half a degree per pixel dragged.
                        st.sun = (st.sun + (position.x - x0) * 5.0)
                            .rem_euclid(f64::from(SUN_STEPS_PER_TURN));
                        st.sun_drag = Some(position.x);
                    }
                    if let Some((x0, y0)) = st.dragging {
                        st.yaw -= ((position.x - x0) * 0.01) as f32;
                        st.pitch = (st.pitch - ((position.y - y0) * 0.01) as f32).clamp(-1.2, 1.2);
                        st.dragging = Some((position.x, position.y));
                        orbit(st)
                    } else {
                        Ok(())
                    }
                }
                None => Ok(()),
            },
            WindowEvent::MouseWheel { delta, .. } => match self.state.as_mut() {
                Some(st) => {
                    let lines = match delta {
                        MouseScrollDelta::LineDelta(_, y) => y,
                        MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                    };
                    st.distance_scale = (st.distance_scale * 0.9f32.powf(lines)).clamp(0.1, 10.0);
                    orbit(st)
                }
                None => Ok(()),
            },
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(st) = &self.state {
            st.window.request_redraw();
        }
    }

    fn exiting(&mut self, _: &ActiveEventLoop) {
        if let Some(mut st) = self.state.take() {
            record_shown(&mut st, &mut self.report);
            if let Some((_, handle)) = st.building.take() {
                let _ = handle.join();
            }
            let stats = TimingStats::from_ms(&st.frame_ms);
            self.report.median_frame_ms = stats.map(|t| t.ms_median);
            self.report.longest_frame_ms = stats.map(|t| t.ms_max);
            self.report.rebuilds = st.rebuild_cpu_ms.len();
            self.report.rebuild_cpu_ms =
                TimingStats::from_ms(&st.rebuild_cpu_ms).map(|t| t.ms_median);
            self.report.longest_swap_frame_ms = st.swap_frames_ms.iter().copied().reduce(f64::max);
            self.report.validation = st.ctx.message_counts();
            drop(st);
        }
    }
}
