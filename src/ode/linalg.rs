//! Dense LU factorisation with partial pivoting for the Newton systems of the implicit methods,
//! real (`f64`) and complex (`Complex64`, for the complex-conjugate eigenvalue pair of the
//! Radau IIA matrix).
//!
//! Systems of dimension above [`SMALL_DIM`] (the larger extended models) go through faer's
//! blocked LU with preallocated scratch; at and below it a plain row-major kernel is used, because
//! for a 3×3 to 8×8 matrix the per-call dispatch of a general library costs more than the O(n³)
//! arithmetic. Both paths allocate only when the solver is built.
// The kernels below step several arrays of one state (stages, weights, tolerances) with one
// index, as the method's equations are written.
#![allow(clippy::needless_range_loop)]

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::perm::PermRef;
use faer::{Mat, MatMut, Par};
use num_complex::Complex64;

/// Dimension up to which the plain kernel is used.
pub const SMALL_DIM: usize = 8;

/// Scalars the LU works over.
pub trait Scalar:
    Copy
    + Default
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + faer::traits::ComplexField
{
    /// A magnitude for pivot choice (|re| + |im| for complex numbers).
    fn mag(self) -> f64;
    /// Whether every part is finite.
    fn finite(self) -> bool;
}

impl Scalar for f64 {
    #[inline]
    fn mag(self) -> f64 {
        self.abs()
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Scalar for Complex64 {
    #[inline]
    fn mag(self) -> f64 {
        self.re.abs() + self.im.abs()
    }
    #[inline]
    fn finite(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}

/// The matrix was singular (a zero or non-finite pivot).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("matrix is singular at pivot {0}")]
pub struct LuError(pub usize);

/// An `n×n` LU factorisation, reused across factorisations of the same size.
pub struct DenseLu<T: Scalar> {
    n: usize,
    /// Small path: row-major factors; large path: unused.
    a: Vec<T>,
    piv: Vec<usize>,
    big: Option<BigLu<T>>,
}

struct BigLu<T: Scalar> {
    lu: Mat<T>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    mem: MemBuffer,
    rhs: Mat<T>,
}

impl<T: Scalar> DenseLu<T> {
    /// Workspace for `n×n` matrices.
    pub fn new(n: usize) -> Self {
        let big = (n > SMALL_DIM).then(|| {
            let req = factor::lu_in_place_scratch::<usize, T>(n, n, Par::Seq, Default::default())
                .or(solve::solve_in_place_scratch::<usize, T>(n, 1, Par::Seq));
            BigLu {
                lu: Mat::zeros(n, n),
                perm: vec![0; n],
                perm_inv: vec![0; n],
                mem: MemBuffer::new(req),
                rhs: Mat::zeros(n, 1),
            }
        });
        DenseLu {
            n,
            a: vec![T::default(); n * n],
            piv: vec![0; n],
            big,
        }
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Factorises the matrix with entries `m(i, j)`.
    pub fn factor(&mut self, m: impl Fn(usize, usize) -> T) -> Result<(), LuError> {
        let n = self.n;
        if let Some(b) = self.big.as_mut() {
            for j in 0..n {
                for i in 0..n {
                    b.lu[(i, j)] = m(i, j);
                }
            }
            factor::lu_in_place(
                b.lu.as_mut(),
                &mut b.perm,
                &mut b.perm_inv,
                Par::Seq,
                MemStack::new(&mut b.mem),
                Default::default(),
            );
            for k in 0..n {
                let p = b.lu[(k, k)];
                if !(p.finite() && p.mag() > 0.0) {
                    return Err(LuError(k));
                }
            }
            return Ok(());
        }
        let a = &mut self.a;
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = m(i, j);
            }
        }
        for k in 0..n {
            // Partial pivoting: the largest entry of column k at or below the diagonal.
            let mut p = k;
            let mut best = a[k * n + k].mag();
            for i in k + 1..n {
                let v = a[i * n + k].mag();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best > 0.0 && best.is_finite()) {
                return Err(LuError(k));
            }
            self.piv[k] = p;
            if p != k {
                for j in 0..n {
                    a.swap(k * n + j, p * n + j);
                }
            }
            let pivot = a[k * n + k];
            for i in k + 1..n {
                let l = a[i * n + k] / pivot;
                a[i * n + k] = l;
                for j in k + 1..n {
                    let u = a[k * n + j];
                    a[i * n + j] -= l * u;
                }
            }
        }
        Ok(())
    }

    /// Solves `A x = b` in place (`b` becomes `x`).
    pub fn solve(&mut self, b: &mut [T]) {
        let n = self.n;
        if let Some(big) = self.big.as_mut() {
            for i in 0..n {
                big.rhs[(i, 0)] = b[i];
            }
            // SAFETY-free: the permutation was produced by lu_in_place for this size.
            let perm = PermRef::new_checked(&big.perm, &big.perm_inv, n);
            let rhs: MatMut<'_, T> = big.rhs.as_mut();
            solve::solve_in_place(
                big.lu.as_ref(),
                big.lu.as_ref(),
                perm,
                rhs,
                Par::Seq,
                MemStack::new(&mut big.mem),
            );
            for i in 0..n {
                b[i] = big.rhs[(i, 0)];
            }
            return;
        }
        let a = &self.a;
        for k in 0..n {
            let p = self.piv[k];
            if p != k {
                b.swap(k, p);
            }
        }
        for i in 1..n {
            let mut s = b[i];
            for j in 0..i {
                s -= a[i * n + j] * b[j];
            }
            b[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for j in i + 1..n {
                s -= a[i * n + j] * b[j];
            }
            b[i] = s / a[i * n + i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check<T: Scalar>(n: usize, make: impl Fn(usize) -> T, close: impl Fn(T, T) -> bool) {
        // A diagonally weighted pseudo-random matrix and a known solution.
        let m = |i: usize, j: usize| make(i * 31 + j * 7 + 3);
        let x: Vec<T> = (0..n).map(|i| make(100 + i)).collect();
        let mut b = vec![T::default(); n];
        for i in 0..n {
            for j in 0..n {
                b[i] += m(i, j) * x[j];
            }
        }
        let mut lu = DenseLu::<T>::new(n);
        lu.factor(m).unwrap();
        lu.solve(&mut b);
        for i in 0..n {
            assert!(close(b[i], x[i]), "n = {n}, component {i}");
        }
    }

    fn r(k: usize) -> f64 {
        // Deterministic values in (-1, 1) with no structure.
        ((k as f64 * 12.9898).sin() * 43758.5453).fract()
    }

    #[test]
    fn real_small_and_large_paths_solve() {
        for n in [1, 2, 3, 5, 8, 9, 12, 20] {
            check::<f64>(n, r, |a, b| (a - b).abs() < 1e-9);
        }
    }

    #[test]
    fn complex_small_and_large_paths_solve() {
        for n in [1, 3, 8, 9, 16] {
            check::<Complex64>(
                n,
                |k| Complex64::new(r(k), r(k + 1000)),
                |a, b| (a - b).norm() < 1e-9,
            );
        }
    }

    #[test]
    fn singular_matrix_is_reported() {
        for n in [3, 10] {
            let mut lu = DenseLu::<f64>::new(n);
            // Two equal rows.
            let res = lu.factor(|i, j| {
                if i <= 1 {
                    (j + 1) as f64
                } else {
                    (i * j) as f64 + if i == j { 1.0 } else { 0.0 }
                }
            });
            assert!(res.is_err(), "n = {n}");
        }
    }
}
