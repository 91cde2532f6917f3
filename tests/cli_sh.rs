//! `shvis sh …` prints what the library computes, at 17 significant digits (DESIGN §4).

use std::io::Write;
use std::process::{Command, Stdio};

use glam::DVec3;
use shvis::sh::Order;
use shvis::sh::basis::eval_basis_vec;

fn run(args: &[&str], stdin: &str) -> String {
    let mut child = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(args)
        .env("RUST_LOG", "off")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(stdin.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout).unwrap()
}

fn numbers(line: &str) -> Vec<f64> {
    line.split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect()
}

#[test]
fn eval_round_trips_the_library_values_exactly() {
    let dirs = [DVec3::Z, DVec3::NEG_Z, DVec3::new(0.48, -0.6, 0.64)];
    let input: String = dirs
        .iter()
        .map(|d| format!("{:.17e} {:.17e} {:.17e}\n", d.x, d.y, d.z))
        .collect();
    let out = run(&["sh", "eval", "--order", "6"], &input);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), dirs.len());
    for (line, d) in lines.iter().zip(dirs) {
        let expected = eval_basis_vec(Order::SIX, d);
        assert_eq!(numbers(line), expected, "at {d}");
    }
}

#[test]
fn irradiance_exact_and_order_3_differ_by_the_truncation_only() {
    // The built-in sky: the order-3 truncation of a small sun is a few percent.
    let exact = numbers(&run(
        &["sh", "irradiance", "--normal", "0,1,0", "--exact"],
        "",
    ));
    let order3 = numbers(&run(&["sh", "irradiance", "--normal", "0,1,0"], ""));
    let order12 = numbers(&run(
        &["sh", "irradiance", "--normal", "0,1,0", "--order", "12"],
        "",
    ));
    for k in 0..3 {
        let e3 = (order3[k] - exact[k]).abs() / exact[k];
        let e12 = (order12[k] - exact[k]).abs() / exact[k];
        assert!(e3 < 0.15, "order-3 truncation {e3}");
        // Odd bands ≥ 3 of the clamped cosine vanish and even ones fall as l^-2.5: order 12
        // is far closer to the quadrature.
        assert!(e12 < 0.25 * e3, "order 12 {e12} vs order 3 {e3}");
    }
}
