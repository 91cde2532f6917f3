//! Sums of outer products with nine rows, the inner loop of the transfer bake's passes
//! (`super::transfer`, eqs. (1) and (3)):
//!
//! ```text
//! S[i][j] += Σ_h a_h[i] · b_h[j]        i < 9, j < N, the terms h in the order given
//! ```
//!
//! Each element is summed term by term in the given order, one multiply and one add per
//! term (no fused multiply-add), so the result is bit for bit the naive loop's. The columns
//! are taken a register's width at a time with the nine partial sums held in registers
//! across every term: a term costs one load of b and nine broadcasts, where the naive loop
//! loads and stores each of the 9·N sums.

use std::ops::{Add, Mul};

/// Rows of every outer product.
pub const OUTER_ROWS: usize = 9;

/// `sums[i·n + j] += Σ_h a[h][i] · b[h][j]` over the terms in order (module doc); `n` is
/// the length of every `b[h]` and `sums` holds 9·n.
///
/// # Panics
/// When `sums` or a `b[h]` is not of that length, or `a` and `b` differ in length (a bug in
/// the caller).
pub fn add_outer_products<T: Lane>(sums: &mut [T], a: &[[T; OUTER_ROWS]], b: &[&[T]]) {
    assert_eq!(a.len(), b.len(), "one row vector per column vector");
    assert_eq!(sums.len() % OUTER_ROWS, 0, "nine rows of sums");
    let n = sums.len() / OUTER_ROWS;
    assert!(
        b.iter().all(|b| b.len() == n),
        "every column vector of length n"
    );
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present (checked just above).
        #[allow(unsafe_code)]
        unsafe {
            T::sum_avx2(sums, a, b)
        };
        return;
    }
    sum_columns::<T>(sums, a, b);
}

/// The element types the sums are taken in, each with the width of its AVX2 register.
pub trait Lane: Copy + Default + Add<Output = Self> + Mul<Output = Self> {
    /// # Safety
    /// AVX2 must be available.
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    unsafe fn sum_avx2(sums: &mut [Self], a: &[[Self; OUTER_ROWS]], b: &[&[Self]]);
}

impl Lane for f32 {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[allow(unsafe_code)]
    unsafe fn sum_avx2(sums: &mut [f32], a: &[[f32; OUTER_ROWS]], b: &[&[f32]]) {
        sum_blocks::<f32, 8>(sums, a, b);
    }
}

impl Lane for f64 {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[allow(unsafe_code)]
    unsafe fn sum_avx2(sums: &mut [f64], a: &[[f64; OUTER_ROWS]], b: &[&[f64]]) {
        sum_blocks::<f64, 4>(sums, a, b);
    }
}

/// Columns in blocks of `W` (one register), the block's 9·W sums held across the terms;
/// the columns after the last whole block one at a time.
#[inline(always)]
fn sum_blocks<T: Lane, const W: usize>(sums: &mut [T], a: &[[T; OUTER_ROWS]], b: &[&[T]]) {
    let n = sums.len() / OUTER_ROWS;
    let whole = n / W * W;
    for j in (0..whole).step_by(W) {
        let mut block = [[T::default(); W]; OUTER_ROWS];
        for (i, row) in block.iter_mut().enumerate() {
            row.copy_from_slice(&sums[i * n + j..][..W]);
        }
        for (a, b) in a.iter().zip(b) {
            let bv: &[T; W] = b[j..j + W].try_into().expect("a whole block");
            for (row, &ai) in block.iter_mut().zip(a) {
                for (s, &bj) in row.iter_mut().zip(bv) {
                    *s = *s + ai * bj;
                }
            }
        }
        for (i, row) in block.iter().enumerate() {
            sums[i * n + j..][..W].copy_from_slice(row);
        }
    }
    sum_columns_from(sums, a, b, whole);
}

/// One column at a time, every column.
fn sum_columns<T: Lane>(sums: &mut [T], a: &[[T; OUTER_ROWS]], b: &[&[T]]) {
    sum_columns_from(sums, a, b, 0);
}

#[inline(always)]
fn sum_columns_from<T: Lane>(sums: &mut [T], a: &[[T; OUTER_ROWS]], b: &[&[T]], first: usize) {
    let n = sums.len() / OUTER_ROWS;
    for j in first..n {
        for i in 0..OUTER_ROWS {
            let mut s = sums[i * n + j];
            for (a, b) in a.iter().zip(b) {
                s = s + a[i] * b[j];
            }
            sums[i * n + j] = s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The naive loop the kernel must equal bit for bit: per term, every element.
    fn naive<T: Lane>(sums: &mut [T], a: &[[T; OUTER_ROWS]], b: &[&[T]]) {
        let n = sums.len() / OUTER_ROWS;
        for (a, b) in a.iter().zip(b) {
            for i in 0..OUTER_ROWS {
                for j in 0..n {
                    sums[i * n + j] = sums[i * n + j] + a[i] * b[j];
                }
            }
        }
    }

    /// Values of mixed signs and magnitudes, so that the order of the additions shows in
    /// the rounding.
    fn values(count: usize, seed: u64) -> Vec<f64> {
        let mut x = seed;
        (0..count)
            .map(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (x >> 11) as f64 / (1u64 << 53) as f64;
                (u - 0.4) * 10f64.powi((x % 7) as i32 - 3)
            })
            .collect()
    }

    fn check<T: Lane + PartialEq + std::fmt::Debug>(to: impl Fn(f64) -> T, n: usize) {
        let terms = 37;
        let a_values = values(terms * OUTER_ROWS, 1);
        let a: Vec<[T; OUTER_ROWS]> = a_values
            .chunks(OUTER_ROWS)
            .map(|c| std::array::from_fn(|i| to(c[i])))
            .collect();
        let b_values: Vec<T> = values(terms * n, 2).into_iter().map(&to).collect();
        let b: Vec<&[T]> = b_values.chunks(n).collect();
        let start: Vec<T> = values(OUTER_ROWS * n, 3).into_iter().map(&to).collect();
        let mut expected = start.clone();
        naive(&mut expected, &a, &b);
        let mut got = start.clone();
        add_outer_products(&mut got, &a, &b);
        assert_eq!(got, expected, "n = {n}");
        let mut scalar = start;
        sum_columns(&mut scalar, &a, &b);
        assert_eq!(scalar, expected, "n = {n}");
    }

    #[test]
    fn equals_the_naive_loop_bit_for_bit() {
        for n in [1, 4, 9, 16, 25, 36, 49, 64, 81] {
            check(|v| v as f32, n);
            check(|v| v, n);
        }
    }

    #[test]
    fn no_terms_leave_the_sums() {
        let mut sums = vec![1.5f32; OUTER_ROWS * 3];
        add_outer_products(&mut sums, &[], &[]);
        assert_eq!(sums, vec![1.5f32; OUTER_ROWS * 3]);
    }
}
