//! The text tools of `shvis sh` (DESIGN §4): SH basis values, projections and irradiance
//! printed for checking the math from outside, one line per item, 17 significant digits
//! (enough to round-trip an f64).

pub mod ssbump;

use std::io::{BufRead, Write};

use glam::DVec3;

use crate::env::{self, EnvError};
use crate::sh::basis::eval_basis;
use crate::sh::{Order, ShError, unit_dir, zonal};

/// Errors of the tools, each one line naming the input.
#[derive(Debug, thiserror::Error)]
pub enum ToolError {
    #[error("{what}: '{text}' is not three numbers")]
    NotADirection { what: String, text: String },
    // `cause`, not `source`: the message already carries it, and a source would be printed
    // twice by the error chain.
    #[error("{what}: {cause}")]
    Direction { what: String, cause: ShError },
    #[error(transparent)]
    Sh(#[from] ShError),
    #[error(transparent)]
    Env(#[from] EnvError),
    #[error("{what}: {cause}")]
    Io {
        what: &'static str,
        cause: std::io::Error,
    },
}

fn fmt17(v: f64) -> String {
    format!("{v:.16e}")
}

fn write_line(out: &mut impl Write, values: &[f64]) -> Result<(), ToolError> {
    let text: Vec<String> = values.iter().map(|&v| fmt17(v)).collect();
    writeln!(out, "{}", text.join(" ")).map_err(|cause| ToolError::Io {
        what: "writing stdout",
        cause,
    })
}

/// A unit direction from "x,y,z" or "x y z" (`what` names the input in errors).
pub fn parse_direction(text: &str, what: &str) -> Result<DVec3, ToolError> {
    let not_three = || ToolError::NotADirection {
        what: what.to_string(),
        text: text.to_string(),
    };
    let values: Vec<f64> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|p| !p.is_empty())
        .map(|p| p.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| not_three())?;
    let [x, y, z] = values[..] else {
        return Err(not_three());
    };
    unit_dir(DVec3::new(x, y, z)).map_err(|cause| ToolError::Direction {
        what: what.to_string(),
        cause,
    })
}

/// `sh eval`: for each direction line of `input` (blank and `#` lines skipped), the order²
/// basis values on one line.
pub fn eval(order: u32, input: impl BufRead, out: &mut impl Write) -> Result<(), ToolError> {
    let order = Order::new(order)?;
    let mut values = vec![0.0; order.coeff_count()];
    for (i, line) in input.lines().enumerate() {
        let line = line.map_err(|cause| ToolError::Io {
            what: "reading stdin",
            cause,
        })?;
        if line.trim().is_empty() || line.trim_start().starts_with('#') {
            continue;
        }
        let dir = parse_direction(&line, &format!("stdin line {}", i + 1))?;
        eval_basis(order, dir, &mut values);
        write_line(out, &values)?;
    }
    Ok(())
}

/// `sh project`: the environment's RGB SH coefficients, one "r g b" line each.
pub fn project(env: &str, order: u32, out: &mut impl Write) -> Result<(), ToolError> {
    let order = Order::new(order)?;
    let env = env::resolve(env)?;
    for c in env::project::project_sh(&env, order) {
        write_line(out, &c)?;
    }
    Ok(())
}

/// `sh irradiance`: E(n) as "r g b", from SH of `order` (default 3) or, with `exact`, by
/// quadrature over the environment's texels.
pub fn irradiance(
    env: &str,
    normal: &str,
    order: Option<u32>,
    exact: bool,
    out: &mut impl Write,
) -> Result<(), ToolError> {
    let n = parse_direction(normal, "--normal")?;
    let order = order.map(Order::new).transpose()?;
    let env = env::resolve(env)?;
    let e = if exact {
        env::project::irradiance_brute_force(&env, n)
    } else {
        let order = order.unwrap_or(Order::THREE);
        let radiance = env::project::project_sh(&env, order);
        zonal::eval_rgb(&zonal::irradiance_from_radiance(&radiance, order), order, n)
    };
    write_line(out, &e)
}
