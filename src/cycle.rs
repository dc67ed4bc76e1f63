//! Continuation of a run without vibration, or of the averaged slow model
//! ([`LimitCycle::slow`]), along its limit cycle.
//!
//! Without vibration the base model, (4.2)–(4.9) with `u' = 0`, is autonomous in the spring
//! stretch `z = v_d t − x`, the velocity `v` and the contact deformation `s`: the state at one
//! instant of a stick-slip cycle decides every later one. Once the run is seen to repeat, the rest
//! of its samples are known, and [`sim`](crate::sim) reads them off the last cycle instead of
//! integrating them.
//!
//! **Section.** The downward crossing of the Coulomb level `F_c` by the drive force. Each slip
//! swings the force about the kinetic friction, which is `F_c` once the slip is much faster than
//! `v_s`, so the crossing lies half-way down every drop, where the force falls fastest and its
//! time is sharpest. It is located on the sampled force by four-point Lagrange interpolation
//! (a cubic through the two samples either side), and the state there by the same weights.
//!
//! **Periodic.** Two successive sections agree to [`AGREEMENT`] error weights
//! `atol·scale_i + rtol·|y_i|` (the integrator's, see [`ode`](crate::ode)) in `z`, `v` and `s`,
//! and between them the body stuck (`|v| <` [`STICK_VELOCITY`]` · v_d`) for at least
//! [`STICK_SHARE`] of the time. The stick makes the test safe: while the body sticks the contact
//! is a spring `k_t` with the damping `h_t` (critical, Table 1), whose transients die at
//! `h_t / 2m ≈ 10⁴ /s`, and the load then climbs the same creep curve to the breakaway whatever the
//! last trough was, so the next section does not depend on the last one. Equal sections with a
//! stick between them therefore mean a periodic solution, not one still converging slowly (as
//! the decaying oscillations of steady sliding do; they never stick and are never continued).
//!
//! **Continuation.** With `T` the time between the two sections, a sample at `t` is the one at
//! `τ = t − mT` inside the last cycle: `z(t) = z(τ)`, `v(t) = v(τ)`, `s(t) = s(τ)`,
//! `x(t) = v_d t − z(τ)` and `F = k_d z + h_d (v_d − v)`, read between samples by cubic Hermite
//! interpolation: for `z` with its exact slope `z' = v_d − v`, for `v` and `s` with Fritsch and
//! Carlson's monotone slopes (a four-point cubic rings across the kink of the re-stick, where the
//! velocity falls to nothing between two samples). Where the motion is smooth on the sampling
//! scale (`ω dt ≤ π/40` with `ω = √(k_d/m)` and the 40 samples per slip of
//! [`sampling`](crate::sim::sampling)) the error of `z`, and so of the force, is about
//! `(ω dt)⁴/400` of the slip's swing; the re-stick, a kink between two samples, costs more: on
//! the paper's ranges the measures agree with those of the integrated run to 1e-4 of dF
//! (`tests/model.rs`).

use crate::measures::STICK_VELOCITY;
use crate::model::{Params, Rig, S, V, X};
use crate::ode::{OdeSystem, Options, OutputGrid};
use std::collections::VecDeque;

/// Two sections agree when every component differs by at most this many error weights
/// `atol·scale_i + rtol·|y_i|`: generous, since the stick between them (see the module docs)
/// already rules out a solution still converging, and the interpolated states carry errors of a
/// few weights at tight tolerances.
pub const AGREEMENT: f64 = 100.0;

/// The body must have stuck for at least this share of the time between two sections.
pub const STICK_SHARE: f64 = 0.1;

/// One section: time and autonomous state `[z, v, s]`.
#[derive(Clone, Copy, Debug)]
struct Section {
    t: f64,
    z: [f64; 3],
}

/// Watches the samples of a run without vibration for a repeating stick-slip cycle and, once
/// found, continues them along it. Built per run by [`sim`](crate::sim); see the module docs.
#[derive(Clone, Debug)]
pub struct LimitCycle {
    /// Sample spacing \[s\]; sample `i` lies at `i · dt`.
    dt: f64,
    /// Section level `F_c` \[N\].
    level: f64,
    v_d: f64,
    k_d: f64,
    h_d: f64,
    stick_v: f64,
    /// Whether two agreeing sections must show the cycle contracting (their gap at most half
    /// the last pair's, or within one error weight) instead of a stick of [`STICK_SHARE`]
    /// between them: the averaged slow model, whose body creeps under vibration.
    contract: bool,
    /// The last pair's gap in error weights (largest over the components).
    last_gap: f64,
    /// Error weights: `atol · scale_i` and `rtol`.
    abs: [f64; 3],
    rtol: f64,
    /// Samples `[F, z, v, s]` from index `first` on: the last three before any section, then
    /// from the sample before the last section's bracket.
    buf: VecDeque<[f64; 4]>,
    first: u64,
    /// Samples stuck since the last section.
    stuck: u64,
    last: Option<Section>,
    /// Once periodic: the period \[s\] and the later of the two agreeing sections.
    found: Option<(f64, Section)>,
}

impl LimitCycle {
    /// A watcher for the rig (without vibration, base model) sampled every `dt` from `t = 0`
    /// and integrated with the tolerances of `ode`.
    pub fn new(rig: &Rig, dt: f64, ode: &Options) -> LimitCycle {
        let abs = [
            ode.atol * rig.scale(X),
            ode.atol * rig.scale(V),
            ode.atol * rig.scale(S),
        ];
        LimitCycle::watching(&rig.p, rig.p.f_c, dt, abs, ode.rtol, false)
    }

    /// A watcher for the averaged slow model of `p` ([`crate::averaged`]: the stretch `z` and the
    /// mean velocity `V`, pushed as `[v_d t − z, V, 0]`) sampled every `dt` from `t = 0` and
    /// integrated at `rtol = atol` with the scales `scale` of `z` and `V`. Its section is the
    /// downward crossing of `level`, the averaged law at `v_d`: the model is planar, so a
    /// periodic orbit encloses its one equilibrium (the slide at `v_d`, where the drive force is
    /// that level) and crosses the level on its way down once per cycle. The body need not
    /// stick (it creeps under vibration); instead two agreeing sections must show the orbit
    /// contracting (their gap at most half the last pair's, or within one error weight), so that
    /// what is left of the transient is within the agreement.
    pub fn slow(p: &Params, level: f64, dt: f64, rtol: f64, scale: [f64; 2]) -> LimitCycle {
        let abs = [rtol * scale[0], rtol * scale[1], 1.0];
        LimitCycle::watching(p, level, dt, abs, rtol, true)
    }

    /// A watcher of the section at `level` with error weights `abs` and `rtol`; `contract`
    /// asks for contraction instead of a stick between agreeing sections.
    fn watching(
        p: &Params,
        level: f64,
        dt: f64,
        abs: [f64; 3],
        rtol: f64,
        contract: bool,
    ) -> LimitCycle {
        // Room for one cycle of samples and its margins (cycle estimate over dt, plus a half).
        let cap = (1.5 * p.cycle_estimate() / dt).clamp(16.0, 1e6) as usize;
        LimitCycle {
            dt,
            level,
            v_d: p.v_d,
            k_d: p.k_d,
            h_d: p.h_d,
            stick_v: STICK_VELOCITY * p.v_d,
            contract,
            last_gap: f64::INFINITY,
            abs,
            rtol,
            buf: VecDeque::with_capacity(cap),
            first: 0,
            stuck: 0,
            last: None,
            found: None,
        }
    }

    /// Takes the next sample (drive force `f` and state `y` at `t = i · dt`, in order from
    /// `i = 0`); returns true once the run is periodic, after which [`LimitCycle::replay`]
    /// gives every later sample.
    pub fn push(&mut self, t: f64, f: f64, y: &[f64]) -> bool {
        if self.found.is_some() {
            return true;
        }
        self.buf.push_back([f, self.v_d * t - y[X], y[V], y[S]]);
        if y[V].abs() < self.stick_v {
            self.stuck += 1;
        }
        let n = self.buf.len();
        if n < 4 {
            return false;
        }
        // Bracket between samples j = n − 3 and j + 1, with j − 1 and j + 2 for the cubic.
        let (fa, fb) = (self.buf[n - 3][0], self.buf[n - 2][0]);
        if !(fa >= self.level && fb < self.level) {
            if self.last.is_none() {
                self.buf.pop_front();
                self.first += 1;
            }
            return false;
        }
        let base = n - 4;
        let u = self.crossing(base);
        let w = weights(u);
        let mut z = [0.0; 3];
        for (c, zc) in z.iter_mut().enumerate() {
            *zc = (0..4).map(|k| w[k] * self.buf[base + k][c + 1]).sum();
        }
        let sec = Section {
            t: (self.first + base as u64 + 1) as f64 * self.dt + u * self.dt,
            z,
        };
        if let Some(prev) = self.last {
            let period = sec.t - prev.t;
            let stuck = self.contract || self.stuck as f64 * self.dt >= STICK_SHARE * period;
            let gap = (0..3).fold(0.0f64, |g, c| {
                let weight = self.abs[c] + self.rtol * sec.z[c].abs().max(prev.z[c].abs());
                g.max((sec.z[c] - prev.z[c]).abs() / weight)
            });
            let contracting = !self.contract || gap <= 1.0 || gap <= 0.5 * self.last_gap;
            self.last_gap = gap;
            if stuck && gap <= AGREEMENT && contracting && period > 0.0 {
                self.found = Some((period, sec));
                self.buf.make_contiguous();
                return true;
            }
        }
        // Keep the samples from j − 1 on: the next cycle's interpolation starts there.
        self.buf.drain(..base);
        self.first += base as u64;
        self.last = Some(sec);
        self.stuck = 0;
        false
    }

    /// Where in `[0, 1]` between samples `base + 1` and `base + 2` the cubic through samples
    /// `base .. base + 4` crosses the level: Newton from the linear estimate, kept in bounds.
    fn crossing(&self, base: usize) -> f64 {
        let f = [
            self.buf[base][0] - self.level,
            self.buf[base + 1][0] - self.level,
            self.buf[base + 2][0] - self.level,
            self.buf[base + 3][0] - self.level,
        ];
        let mut u = f[1] / (f[1] - f[2]);
        for _ in 0..4 {
            let w = weights(u);
            let d = derivative_weights(u);
            let p: f64 = (0..4).map(|k| w[k] * f[k]).sum();
            let dp: f64 = (0..4).map(|k| d[k] * f[k]).sum();
            if dp == 0.0 || !dp.is_finite() {
                break;
            }
            u = (u - p / dp).clamp(0.0, 1.0);
        }
        u
    }

    /// The time of the section from which the run is continued \[s\], once found.
    pub fn continued_from(&self) -> Option<f64> {
        self.found.map(|(_, s)| s.t)
    }

    /// Once periodic, calls `each(i, t, F, [x, v, s])` for the samples `i = from .. grid.count`
    /// (all later than the last one pushed), read off the last cycle; nothing before.
    pub fn replay(
        &self,
        grid: &OutputGrid,
        from: u64,
        t_end: f64,
        mut each: impl FnMut(u64, f64, f64, &[f64]),
    ) {
        let Some((period, sec)) = self.found else {
            return;
        };
        // Contiguous since the cycle was found.
        let (buf, _) = self.buf.as_slices();
        let inv_dt = 1.0 / self.dt;
        let first = self.first as f64;
        // Whole periods back from t, the fewest that land in the last cycle (t_n − T, t_n].
        let mut m = 1.0;
        for i in from..grid.count {
            let t = grid.time(i);
            // As the integrator does: a grid time past the span by round-off is not reported.
            if t > t_end {
                break;
            }
            while t - m * period > sec.t {
                m += 1.0;
            }
            let pos = (t - m * period) * inv_dt - first;
            let j = (pos.max(0.0) as usize).clamp(1, buf.len() - 3);
            let u = pos - j as f64;
            let nodes = &buf[j - 1..j + 3];
            // Cubic Hermite on [j, j + 1] (slopes per sample spacing): for the stretch with its
            // exact slope z' = v_d − v, for v and s with monotone slopes.
            let (h00, h01) = (
                (1.0 + 2.0 * u) * (1.0 - u) * (1.0 - u),
                u * u * (3.0 - 2.0 * u),
            );
            let (h10, h11) = (u * (1.0 - u) * (1.0 - u), u * u * (u - 1.0));
            let hermite = |c: usize, d0: f64, d1: f64| {
                h00 * nodes[1][c] + h01 * nodes[2][c] + h10 * d0 + h11 * d1
            };
            let z = hermite(
                1,
                (self.v_d - nodes[1][2]) * self.dt,
                (self.v_d - nodes[2][2]) * self.dt,
            );
            let monotone = |c: usize| {
                let d = [
                    nodes[1][c] - nodes[0][c],
                    nodes[2][c] - nodes[1][c],
                    nodes[3][c] - nodes[2][c],
                ];
                hermite(c, monotone_slope(d[0], d[1]), monotone_slope(d[1], d[2]))
            };
            let (v, s) = (monotone(2), monotone(3));
            // (4.3, 4.4) without vibration and effects.
            let f = self.k_d * z + self.h_d * (self.v_d - v);
            each(i, t, f, &[self.v_d * t - z, v, s]);
        }
    }
}

/// The slope at a sample from the differences `a` and `b` on either side (unit spacing): their
/// harmonic mean, or zero at an extremum (Fritsch and Carlson's monotone choice), so that the
/// cubic never overshoots the samples where the motion has a kink between them.
fn monotone_slope(a: f64, b: f64) -> f64 {
    if a * b > 0.0 {
        2.0 * a * b / (a + b)
    } else {
        0.0
    }
}

/// Lagrange weights of the nodes −1, 0, 1, 2 at `u`.
fn weights(u: f64) -> [f64; 4] {
    [
        -u * (u - 1.0) * (u - 2.0) / 6.0,
        (u + 1.0) * (u - 1.0) * (u - 2.0) / 2.0,
        -(u + 1.0) * u * (u - 2.0) / 2.0,
        (u + 1.0) * u * (u - 1.0) / 6.0,
    ]
}

/// Derivatives of [`weights`] with respect to `u`.
fn derivative_weights(u: f64) -> [f64; 4] {
    [
        -(3.0 * u * u - 6.0 * u + 2.0) / 6.0,
        (3.0 * u * u - 4.0 * u - 1.0) / 2.0,
        -(3.0 * u * u - 2.0 * u - 2.0) / 2.0,
        (3.0 * u * u - 1.0) / 6.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lagrange_weights_reproduce_cubics_exactly() {
        // A cubic through the nodes −1, 0, 1, 2 is its own interpolant; so is its derivative.
        let q = |x: f64| 0.3 * x * x * x - 1.2 * x * x + 0.7 * x - 2.0;
        let dq = |x: f64| 0.9 * x * x - 2.4 * x + 0.7;
        let nodes = [q(-1.0), q(0.0), q(1.0), q(2.0)];
        for u in [0.0, 0.17, 0.5, 0.93, 1.0] {
            let w = weights(u);
            let d = derivative_weights(u);
            let p: f64 = (0..4).map(|k| w[k] * nodes[k]).sum();
            let dp: f64 = (0..4).map(|k| d[k] * nodes[k]).sum();
            assert!((p - q(u)).abs() < 1e-13, "u {u}: {p} vs {}", q(u));
            assert!((dp - dq(u)).abs() < 1e-13, "u {u}: {dp} vs {}", dq(u));
        }
    }
}
