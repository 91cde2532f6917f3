//! The references a bench measures against (`crate::reference`): the footprint reference
//! (or the point one), its inter-reflected twin where a technique bakes inter-reflection, the
//! point reference beside a footprint one (the ladder's first rung), and with `--specular`
//! the specular term's own reference summed in.

use std::sync::Arc;
use std::time::Instant;

use super::{BenchError, BenchSettings};
use crate::gpu::Context;
use crate::prepare::Prepared;
use crate::reference::{ReferenceImage, ReferenceSettings, render_reference};
use crate::render::specular::{NormalFilter, SpecularTerm};
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::report::bench_output::BenchOutput;
use crate::report::table::RowReference;
use crate::technique::{ReferenceModel, Technique};

/// The references a bench measures against.
pub struct References {
    /// What the error column is against: the footprint reference (or the point one with
    /// `--point-reference`), with the inter-reflected image when a technique needs it.
    pub main: ReferenceImage,
    /// With a footprint `main`: the point-sampled reference from the same samples'
    /// settings, the first rung of the error attribution.
    pub point: Option<ReferenceImage>,
}

/// The references: `main`, written as `reference*.{exr,png}`, and with a footprint main
/// the point-sampled one as `reference_point*.{exr,png}`.
pub(super) fn render_references(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    env: &crate::env::EnvMap,
    settings: &BenchSettings,
    out: &BenchOutput,
) -> Result<Option<References>, BenchError> {
    if settings.ref_spp == 0 {
        return Ok(None);
    }
    let render = |footprint: bool, name: &str| -> Result<ReferenceImage, BenchError> {
        let reference_settings = ReferenceSettings {
            width: settings.width,
            height: settings.height,
            spp: settings.ref_spp,
            seed: settings.seed,
            bounces: if settings.needs_inter_reflection() {
                settings.bounces
            } else {
                0
            },
            footprint,
        };
        let mut image = render_reference(ctx, &prepared.scene, env, &reference_settings)?;
        if let Some(s) = &settings.specular {
            let term = s.term(NormalFilter::Mip);
            let specular = specular_reference(ctx, prepared, &term, &reference_settings)?;
            add_rgb(&mut image.frame, &specular);
            if let Some(b) = &mut image.bounced {
                add_rgb(&mut b.frame, &specular);
            }
        }
        log::info!(
            "{name}: {} spp ({}×{} sub-pixel strata) in {:.1} s, relative noise {:.4}",
            settings.ref_spp,
            image.strata.side,
            image.strata.side,
            image.seconds,
            image.rel_noise
        );
        out.images(name, &image.frame)?;
        if let Some(b) = &image.bounced {
            log::info!(
                "{name} with {} bounces: relative noise {:.4}",
                b.bounces,
                b.rel_noise
            );
            let file = format!("{name}_bounces{}", b.bounces);
            out.images(&file, &b.frame)?;
        }
        Ok(image)
    };
    let main = render(settings.footprint_reference, "reference")?;
    let point = if settings.footprint_reference {
        Some(render(false, "reference_point")?)
    } else {
        None
    };
    Ok(Some(References { main, point }))
}

/// The footprint (or, without `settings.footprint`, point) reference of the specular term
/// alone: the same BRDF from the full-resolution normals (`reference::specular::render_reference`).
fn specular_reference(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    term: &SpecularTerm,
    settings: &ReferenceSettings,
) -> Result<Frame, BenchError> {
    let mut gpu = SceneGpu::new(
        ctx,
        &prepared.scene,
        &FrameSettings {
            width: settings.width,
            height: settings.height,
            float32_target: true,
            ..FrameSettings::default()
        },
    )?;
    let maps = crate::ndf::build(
        &prepared.scene.material.normal,
        prepared.scene.material.normal_scale,
        term.sigma,
    );
    let started = Instant::now();
    let frame = crate::reference::specular::render_reference(
        ctx,
        &mut gpu,
        prepared.scene.camera.position,
        &maps,
        &term.light,
        settings,
    )?;
    log::info!(
        "specular reference ({}): {:.1} s",
        if settings.footprint {
            "footprint"
        } else {
            "point"
        },
        started.elapsed().as_secs_f64()
    );
    Ok(frame)
}

/// Adds `extra`'s colour to `frame` (same size), alpha kept.
fn add_rgb(frame: &mut Frame, extra: &Frame) {
    for (p, e) in frame.rgba.iter_mut().zip(&extra.rgba) {
        for c in 0..3 {
            p[c] += e[c];
        }
    }
}

/// The image of `reference` a technique is measured against, and how the row names it.
pub(super) fn reference_for(
    technique: Technique,
    reference: &ReferenceImage,
) -> (&Frame, RowReference) {
    match (technique.reference(), &reference.bounced) {
        (ReferenceModel::InterReflected, Some(b)) => (&b.frame, RowReference::Bounced(b.bounces)),
        (ReferenceModel::InterReflected, None) | (ReferenceModel::Direct, _) => {
            (&reference.frame, RowReference::Direct)
        }
    }
}

/// The file stem of the reference image `frame` was taken from (`reference_for`).
pub(super) fn reference_stem(name: &str, kind: RowReference) -> String {
    match kind {
        RowReference::Bounced(n) => format!("{name}_bounces{n}"),
        RowReference::Direct | RowReference::None => name.to_string(),
    }
}
