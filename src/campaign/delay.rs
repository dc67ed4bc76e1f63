//! The sampling of a simulated recording, with a recorded force that may lag the sensor's
//! output by a time (`sensor_dynamics` in its `order4_delay` form: an acquisition channel's
//! anti-alias filter, then its converter's delay).
//!
//! A delay has no place in the state of an ordinary differential equation, so it acts where the
//! recording is sampled: the force recorded at `t_i` is the filter's output at `t_i − τ`. The
//! run is sampled on the recording's grid, started early enough to reach `t_0 − τ` (never
//! before `t = 0`, where the sensor rests), and each sample keeps the filter's output and its
//! first three time derivatives, all exact functions of the state
//! ([`crate::model::Rig::sensor_output_derivatives`]). Between two samples the output at
//! `t_i − τ` is the two-point Hermite interpolant of degree 7 of those values. For a
//! component of frequency `ν` the interpolant errs by about `(2πν Δt)^8 / (2^8 8!)` of its
//! amplitude (the remainder of the Hermite form at mid-interval): 1e-3 at `ν = 1/(2 Δt)`,
//! the Nyquist frequency, 1e-8 at a quarter of it. A delay of whole samples reproduces the
//! samples themselves.

use super::SimTrace;
use crate::model::Rig;
use crate::ode::{OutputGrid, Status};

/// The samples of one simulated recording, as the stand's recorder takes them: the recorded
/// force, the body's and the drive's displacement, and (with a sensor delay) the filter's
/// output before the delay.
pub(crate) struct Sampler {
    rig: Rig,
    out: SimTrace,
    /// Samples asked for.
    n: usize,
    /// Samples taken before the recording's first, for the delayed force.
    lead: usize,
    /// Samples seen.
    seen: usize,
    /// The grid's first time \[s\] and spacing \[s\].
    start: f64,
    dt: f64,
    /// The filter's output and its derivatives at each sample seen (with a delay only).
    hist: Vec<[f64; 4]>,
}

impl Sampler {
    /// The sampler of `n` samples at `t0 + i dt` of `rig`, and the grid to integrate on.
    pub(crate) fn new(rig: Rig, t0: f64, dt: f64, n: usize) -> (Sampler, OutputGrid) {
        let tau = rig.sensor_delay();
        Sampler::covering(rig, t0, dt, n, tau)
    }

    /// As [`Sampler::new`], with a grid that starts early enough for a sensor delay up to
    /// `tau` (at least `rig`'s own), for samplers of rigs beside it ([`Sampler::alike`]).
    pub(crate) fn covering(
        rig: Rig,
        t0: f64,
        dt: f64,
        n: usize,
        tau: f64,
    ) -> (Sampler, OutputGrid) {
        let tau = tau.max(rig.sensor_delay());
        // Enough samples before t0 to bracket t0 − τ, none before t = 0.
        let lead = if tau > 0.0 {
            ((tau / dt).ceil() as usize + 1).min((t0 / dt).floor().max(0.0) as usize)
        } else {
            0
        };
        let start = t0 - dt * lead as f64;
        let grid = OutputGrid {
            start,
            step: dt,
            count: (n + lead) as u64,
        };
        let hist = if tau > 0.0 {
            Vec::with_capacity(n + lead)
        } else {
            Vec::new()
        };
        let out = SimTrace {
            f_d: Vec::with_capacity(n),
            x_s: Vec::with_capacity(n),
            x_d: Vec::with_capacity(n),
            status: Status::Success,
        };
        let s = Sampler {
            rig,
            out,
            n,
            lead,
            seen: 0,
            start,
            dt,
            hist,
        };
        (s, grid)
    }

    /// A sampler of `rig` on this one's grid, nothing taken yet.
    pub(crate) fn alike(&self, rig: Rig) -> Sampler {
        let tau = rig.sensor_delay();
        Sampler {
            rig,
            out: SimTrace {
                f_d: Vec::with_capacity(self.n),
                x_s: Vec::with_capacity(self.n),
                x_d: Vec::with_capacity(self.n),
                status: Status::Success,
            },
            n: self.n,
            lead: self.lead,
            seen: 0,
            start: self.start,
            dt: self.dt,
            hist: if tau > 0.0 {
                Vec::with_capacity(self.n + self.lead)
            } else {
                Vec::new()
            },
        }
    }

    /// Takes the sample at grid time `t` of state `y`.
    #[inline]
    pub(crate) fn take(&mut self, t: f64, y: &[f64]) {
        if self.rig.sensor_delay() > 0.0 {
            self.hist.push(self.rig.sensor_output_derivatives(y));
        }
        self.seen += 1;
        if self.seen <= self.lead {
            return;
        }
        self.out.f_d.push(self.rig.measured_force(t, y));
        self.out.x_s.push(y[crate::model::X]);
        self.out.x_d.push(self.rig.drive_displacement(t));
    }

    /// The trace: its status, NaN for the samples a failed run left (so features say so), and
    /// the force delayed where the sensor delays it.
    pub(crate) fn finish(mut self, status: Status) -> SimTrace {
        let n = self.n;
        self.out.status = status;
        for v in [&mut self.out.f_d, &mut self.out.x_s, &mut self.out.x_d] {
            v.resize(n, f64::NAN);
        }
        let tau = self.rig.sensor_delay();
        if tau > 0.0 {
            let rest = self
                .rig
                .sensor_output_derivatives(&self.rig.initial_state());
            let t0 = self.start + self.dt * self.lead as f64;
            for (i, f) in self.out.f_d.iter_mut().enumerate() {
                let q = t0 + self.dt * i as f64 - tau;
                *f = delayed(&self.hist, self.start, self.dt, &rest, q);
            }
        }
        self.out
    }
}

/// The filter's output at time `q` from `hist` (output and derivatives at `start + k dt`) and
/// its state at rest `rest` (before `t = 0`, and the node at `t = 0` where `start > 0`); NaN
/// past the samples taken.
fn delayed(hist: &[[f64; 4]], start: f64, dt: f64, rest: &[f64; 4], q: f64) -> f64 {
    if q <= 0.0 {
        return rest[0];
    }
    if q < start {
        return hist
            .first()
            .map_or(f64::NAN, |b| hermite(rest, b, start, q / start));
    }
    let x = (q - start) / dt;
    let j = x.floor() as usize;
    match (hist.get(j), hist.get(j + 1)) {
        (Some(a), Some(b)) => hermite(a, b, dt, x - j as f64),
        (Some(a), None) if x == j as f64 => a[0],
        _ => f64::NAN,
    }
}

/// The Hermite interpolant of degree 7 at `s ∈ [0, 1]` of an interval of length `h` whose ends
/// have values and first three derivatives `a` and `b`: Newton's form on the nodes
/// `0, 0, 0, 0, 1, 1, 1, 1` (in units of `h`), its confluent divided differences the scaled
/// derivatives `h^k f^(k) / k!`.
fn hermite(a: &[f64; 4], b: &[f64; 4], h: f64, s: f64) -> f64 {
    const Z: [f64; 8] = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let scaled = |d: &[f64; 4], k: usize| -> f64 {
        let fact = [1.0, 1.0, 2.0, 6.0][k];
        d[k] * h.powi(k as i32) / fact
    };
    let mut c = [a[0], a[0], a[0], a[0], b[0], b[0], b[0], b[0]];
    for l in 1..8 {
        for i in (l..8).rev() {
            c[i] = if Z[i] == Z[i - l] {
                scaled(if Z[i] == 0.0 { a } else { b }, l)
            } else {
                (c[i] - c[i - 1]) / (Z[i] - Z[i - l])
            };
        }
    }
    let mut p = c[7];
    for i in (0..7).rev() {
        p = p * (s - Z[i]) + c[i];
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A polynomial of degree 7 is its own interpolant (closed form), on any interval.
    #[test]
    fn the_interpolant_reproduces_a_polynomial_of_degree_seven() {
        let c = [0.3, -1.2, 0.7, 2.1, -0.4, 0.9, -1.5, 0.25];
        let f = |t: f64, k: usize| -> f64 {
            // The k-th derivative of Σ c_m t^m.
            (k..8)
                .map(|m| {
                    let fall: f64 = (0..k).map(|j| (m - j) as f64).product();
                    c[m] * fall * t.powi((m - k) as i32)
                })
                .sum()
        };
        let (t0, h) = (0.7, 0.45);
        let a = [f(t0, 0), f(t0, 1), f(t0, 2), f(t0, 3)];
        let b = [f(t0 + h, 0), f(t0 + h, 1), f(t0 + h, 2), f(t0 + h, 3)];
        for i in 0..=10 {
            let s = i as f64 / 10.0;
            let want = f(t0 + s * h, 0);
            let got = hermite(&a, &b, h, s);
            assert!(
                (got - want).abs() < 1e-12 * want.abs().max(1.0),
                "{s}: {got} {want}"
            );
        }
    }

    /// A sinusoid at half the Nyquist frequency, interpolated from samples: within the stated
    /// bound `(2πν Δt)^8 / (2^8 8!)` of its amplitude; at the samples themselves, exact.
    #[test]
    fn a_sinusoid_between_samples_is_within_the_stated_bound() {
        let (nu, dt) = (250.0, 1e-3);
        let w = std::f64::consts::TAU * nu;
        let d = |t: f64| {
            let (s, c) = (w * t).sin_cos();
            [s, w * c, -w * w * s, -w * w * w * c]
        };
        let hist: Vec<[f64; 4]> = (0..40).map(|k| d(0.01 + k as f64 * dt)).collect();
        let bound = (w * dt).powi(8) / (256.0 * 40320.0);
        let mut worst: f64 = 0.0;
        for i in 0..3900 {
            let q = 0.01 + i as f64 * 1e-5;
            worst = worst.max((delayed(&hist, 0.01, dt, &[0.0; 4], q) - (w * q).sin()).abs());
        }
        assert!(
            worst < bound && worst > 0.01 * bound,
            "{worst} against {bound}"
        );
        let at = delayed(&hist, 0.01, dt, &[0.0; 4], 0.01 + 7.0 * dt);
        assert!((at - hist[7][0]).abs() < 1e-14, "{at}");
    }
}
