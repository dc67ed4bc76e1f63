//! The law `F_eff(V)` tabulated by continuation along the family of orbits, its lookups, its
//! text form (for journals), and the escape force below the contact resonance.

use crate::averaged::orbit::{AveragingError, AveragingOptions, Fast, FastBase, Orbit, Shooter};
use crate::model::Params;
use crate::ode::{Method, Options, OutputGrid, Solver, Span, Status};
use std::cmp::Ordering;

/// `F_eff(V)` tabulated on `0 ≤ V ≤ V_max` (odd in `V`: `F_eff(−V) = −F_eff(V)`), with the orbit
/// at every node.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// The nodes, by increasing `V`.
    pub nodes: Vec<Orbit>,
    /// Where continuation stopped before `V_max` (no converged orbit beyond): the first `V` it
    /// could not reach \[m/s\].
    pub stopped_at: Option<f64>,
    /// Intervals `(V_lo, V_hi)` \[m/s\] between two nodes whose midpoint has no period-1 orbit
    /// (continued from either end): the fast motion there is not periodic with the forcing
    /// (period doubling, chaos, a fold), and the law is undefined.
    pub gaps: Vec<(f64, f64)>,
    /// The nodes' `V` alone, for the lookups of the slow model's every step.
    pub(crate) at: Vec<f64>,
    /// Per interval `k` (nodes `k − 1` and `k`; entry 0 unused): bit 0 set where it is no gap,
    /// bit 1 where, besides, both nodes' orbits contract ([`Table::valid_at`]).
    flags: Vec<u8>,
}

impl Table {
    /// Builds the table for `p` from `V = 0` to `v_max`: continuation along the family of
    /// orbits (each node starts from the last one's orbit moved along its tangent), nodes
    /// bisected until every midpoint agrees with the Hermite cubic of its neighbours to
    /// `force_tol` (each midpoint's orbit, found for the check from the cubic of its neighbours'
    /// starts and tangents, stays a node).
    pub fn build(p: &Params, v_max: f64, opts: AveragingOptions) -> Result<Table, AveragingError> {
        if !(v_max > 0.0 && v_max.is_finite()) {
            return Err(AveragingError::Invalid(format!(
                "v_max = {v_max} m/s: must be finite and > 0"
            )));
        }
        let tol = opts.force_tol;
        let max_nodes = opts.max_nodes;
        let quick = opts.validity_only;
        let mut sh = Shooter::new(p, opts)?;
        // V = 0: by symmetry the orbit has F = 0; Newton starts from rest.
        let first = sh.orbit(0.0, [0.0, 0.0, 0.0])?;
        let mut nodes = vec![first];
        let mut stopped_at = None;
        // Coarse continuation, each step halved where Newton fails: 16 even steps up to the
        // knee (four times the larger of v_a and v_d: the law's peak near v_a, the slow
        // model's velocities near v_d, and the zones where the orbit loses stability lie
        // there), doubling beyond it, where the law flattens towards the base friction.
        let knee = (4.0 * p.v_a().max(p.v_d)).min(v_max);
        let mut coarse: Vec<f64> = (1..=16).map(|k| knee * k as f64 / 16.0).collect();
        let mut j = 1;
        while knee * f64::from(1u32 << j.min(30)) < v_max && j < 30 {
            coarse.push(knee * f64::from(1u32 << j));
            j += 1;
        }
        if knee < v_max {
            coarse.push(v_max);
        }
        let mut k = 0;
        while k < coarse.len() {
            let v = coarse[k];
            match reach(&mut sh, nodes.last().expect("one node"), v) {
                Ok(o) => {
                    nodes.push(o);
                    k += 1;
                }
                Err(_) => {
                    stopped_at = Some(v);
                    break;
                }
            }
        }
        if quick && stopped_at.is_some() {
            return Ok(Table::of(nodes, stopped_at, vec![]));
        }
        // Refinement, left to right: an interval whose midpoint the cubic misses is split and its
        // halves looked at in turn; one whose midpoint has no orbit (from either end) is a gap.
        let mut gaps = vec![];
        let mut done = vec![nodes[0]];
        let mut pending: Vec<Orbit> = nodes[1..].iter().rev().copied().collect();
        let mut left = nodes[0];
        while let Some(right) = pending.pop() {
            if done.len() + pending.len() + 1 >= max_nodes {
                done.push(right);
                left = right;
                continue;
            }
            let mid = 0.5 * (left.v_mean + right.v_mean);
            // Inside a zone whose orbits do not contract the law may not serve: no refinement.
            if quick && !left.contracting() && !right.contracting() {
                done.push(right);
                left = right;
                continue;
            }
            // The midpoint's start from the cubic of both ends (values and tangents): Newton
            // then takes 1.4 iterations per orbit for 1.9 from one end's tangent, and its first
            // period, nearer the orbit, fewer steps (at 3000 Hz, `v_a/v_d` 0.4: 0.68 of the
            // right-hand sides). Where it fails, continuation from either end.
            let found = sh
                .orbit(mid, between(&left, &right, mid))
                .or_else(|_| reach(&mut sh, &left, mid))
                .or_else(|_| reach(&mut sh, &right, mid));
            match found {
                Ok(o) if (hermite(&left, &right, mid) - o.force).abs() > tol => {
                    pending.push(right);
                    pending.push(o);
                }
                // The midpoint's orbit, found for the check, is kept: it costs nothing more and
                // the law between the halves is closer still (at 3000 Hz, `v_a/v_d` 0.4, within
                // 1.8e-4 N of a table at `rtol` 1e-9 and `force_tol` 1e-5 N, for 8e-4 N).
                Ok(o) => {
                    done.push(o);
                    done.push(right);
                    left = right;
                }
                Err(_) => {
                    gaps.push((left.v_mean, right.v_mean));
                    done.push(right);
                    left = right;
                }
            }
        }
        Ok(Table::of(done, stopped_at, gaps))
    }

    /// The table of these nodes (by increasing `V`), with its lookup arrays.
    fn of(nodes: Vec<Orbit>, stopped_at: Option<f64>, gaps: Vec<(f64, f64)>) -> Table {
        let at: Vec<f64> = nodes.iter().map(|o| o.v_mean).collect();
        let flags = (0..nodes.len())
            .map(|k| {
                if k == 0 {
                    return 0;
                }
                let (l, r) = (&nodes[k - 1], &nodes[k]);
                let mid = 0.5 * (l.v_mean + r.v_mean);
                let open = !gaps.iter().any(|&(lo, hi)| mid > lo && mid < hi);
                u8::from(open) | (u8::from(open && l.contracting() && r.contracting()) << 1)
            })
            .collect();
        Table {
            nodes,
            stopped_at,
            gaps,
            at,
            flags,
        }
    }

    /// `F_eff(V)` \[N\] by cubic Hermite interpolation on the exact slopes; odd in `V`. `None`
    /// beyond the table or inside a gap.
    pub fn force(&self, v: f64) -> Option<f64> {
        self.law(v).map(|(f, _)| f)
    }

    /// `dF_eff/dV` \[N s/m\] of the interpolant; even in `V`. `None` beyond the table or inside
    /// a gap.
    pub fn slope(&self, v: f64) -> Option<f64> {
        self.law(v).map(|(_, d)| d)
    }

    /// [`Table::force`] and [`Table::slope`] at `v` from one lookup.
    pub fn law(&self, v: f64) -> Option<(f64, f64)> {
        let a = v.abs();
        let k = self.interval(a)?;
        let (l, r) = (&self.nodes[k - 1], &self.nodes[k.min(self.nodes.len() - 1)]);
        let h = r.v_mean - l.v_mean;
        if h <= 0.0 {
            return Some((l.force.copysign(v), l.slope));
        }
        let f = hermite(l, r, a);
        let s = (a - l.v_mean) / h;
        let d00 = 6.0 * s * s - 6.0 * s;
        let d10 = 3.0 * s * s - 4.0 * s + 1.0;
        let d11 = 3.0 * s * s - 2.0 * s;
        let d = d00 * (l.force - r.force) / h + d10 * l.slope + d11 * r.slope;
        Some((if v < 0.0 { -f } else { f }, d))
    }

    /// Index `k ≥ 1` of the interval (nodes `k − 1`, `k`) around `|V| = a` (`k` = 1 with one
    /// node, which then stands twice); `None` beyond the table or inside a gap.
    fn interval(&self, a: f64) -> Option<usize> {
        let last = *self.at.last()?;
        if !matches!(a.partial_cmp(&last), Some(Ordering::Less | Ordering::Equal)) {
            return None;
        }
        let k = self.at.partition_point(|&x| x < a).max(1);
        if k < self.nodes.len() && self.flags[k] & 1 == 0 && a > self.at[k - 1] && a < self.at[k] {
            return None;
        }
        Some(k)
    }

    /// Whether every node's orbit is [`Orbit::contracting`] and the table has no gap and
    /// reaches its `V_max`: it may stand for the fast vibration everywhere it reaches.
    pub fn valid(&self) -> bool {
        self.stopped_at.is_none()
            && self.gaps.is_empty()
            && self.nodes.iter().all(Orbit::contracting)
    }

    /// Whether the law may stand for the fast vibration at mean velocity `v`: both nodes
    /// around `|v|` have contracting orbits and no gap lies between them; beyond the last node,
    /// where the table reached its end and that node's orbit contracts.
    pub fn valid_at(&self, v: f64) -> bool {
        let a = v.abs();
        let Some(last) = self.nodes.last() else {
            return false;
        };
        if a > last.v_mean {
            return self.stopped_at.is_none() && last.contracting();
        }
        match self.interval(a) {
            Some(k) if k < self.nodes.len() => self.flags[k] & 2 != 0,
            // A one-node table.
            Some(_) => last.contracting(),
            None => false,
        }
    }
}

impl Table {
    /// The fast state `(v(0), s(0))` at phase 0 of the orbit at mean velocity `v`, for a hand-over
    /// to the full model: linear between the nodes around `v`, the end node's beyond the table,
    /// across a gap the nearer node's; at `v < 0` (a body sliding back, which the law's symmetry
    /// maps to phase `π`, not 0) the orbit at rest's. The full model settles onto its own orbit
    /// from there within a few periods.
    pub fn start_at(&self, v: f64) -> [f64; 2] {
        let a = v.max(0.0);
        let n = self.nodes.len();
        let k = self.at.partition_point(|&x| x < a).clamp(1, n.max(2) - 1);
        let (lo, hi) = (&self.nodes[(k - 1).min(n - 1)], &self.nodes[k.min(n - 1)]);
        let h = hi.v_mean - lo.v_mean;
        let w = if h > 0.0 {
            ((a - lo.v_mean) / h).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let gap = k < n && self.flags[k] & 1 == 0;
        let w = if gap { w.round() } else { w };
        [
            lo.start[0] + w * (hi.start[0] - lo.start[0]),
            lo.start[1] + w * (hi.start[1] - lo.start[1]),
        ]
    }
}

impl Table {
    /// The `V` of least modulus in `[lo, hi]` where the law may not stand for the vibration
    /// ([`Table::valid_at`] false), `None` where it may everywhere in the range.
    pub fn first_invalid(&self, lo: f64, hi: f64) -> Option<f64> {
        // The moduli visited: a range through zero covers [0, max |V|].
        let (a, b) = if lo <= 0.0 && hi >= 0.0 {
            (0.0, (-lo).max(hi))
        } else {
            (lo.abs().min(hi.abs()), lo.abs().max(hi.abs()))
        };
        let sign = if hi < 0.0 { -1.0 } else { 1.0 };
        let n = self.nodes.len();
        let Some(&last) = self.at.last() else {
            return Some(sign * a);
        };
        if n >= 2 {
            let first = self.at.partition_point(|&x| x < a).max(1);
            for k in first..n {
                if self.at[k - 1] > b {
                    break;
                }
                if self.flags[k] & 2 == 0 {
                    return Some(sign * a.max(self.at[k - 1]));
                }
            }
        }
        if b > last && !self.valid_at(b) {
            return Some(sign * a.max(last));
        }
        (n == 1 && !self.valid_at(a)).then_some(sign * a)
    }
}

impl Table {
    /// The table as space-separated fields, every float in its shortest round-trip form (so a
    /// table read back is the one written, bit for bit): `V_stop` (NaN where the continuation
    /// reached its end), the gap count and each gap's ends, the node count and per node
    /// `V, F, F', tangent (2), start (2), multipliers (4), fast (2), iterations, rhs_evals`.
    pub fn to_fields(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = write!(
            s,
            "{:e} {}",
            self.stopped_at.unwrap_or(f64::NAN),
            self.gaps.len()
        );
        for (lo, hi) in &self.gaps {
            let _ = write!(s, " {lo:e} {hi:e}");
        }
        let _ = write!(s, " {}", self.nodes.len());
        for o in &self.nodes {
            let m = o.multipliers;
            for x in [
                o.v_mean,
                o.force,
                o.slope,
                o.tangent[0],
                o.tangent[1],
                o.start[0],
                o.start[1],
                m[0].0,
                m[0].1,
                m[1].0,
                m[1].1,
                o.fast.0,
                o.fast.1,
            ] {
                let _ = write!(s, " {x:e}");
            }
            let _ = write!(s, " {} {}", o.iterations, o.rhs_evals);
        }
        s
    }

    /// The table of [`Table::to_fields`]; `None` where a field is missing, malformed or left
    /// over.
    pub fn from_fields(s: &str) -> Option<Table> {
        let mut it = s.split_ascii_whitespace();
        let mut x = || it.next()?.parse::<f64>().ok();
        let stop = x()?;
        let n_gaps = x()?;
        if !(n_gaps >= 0.0 && n_gaps.fract() == 0.0 && n_gaps < 1e6) {
            return None;
        }
        let mut gaps = Vec::with_capacity(n_gaps as usize);
        for _ in 0..n_gaps as usize {
            gaps.push((x()?, x()?));
        }
        let n = x()?;
        if !(n >= 1.0 && n.fract() == 0.0 && n <= 100_000.0) {
            return None;
        }
        let mut nodes = Vec::with_capacity(n as usize);
        for _ in 0..n as usize {
            let mut v = [0.0; 13];
            for e in v.iter_mut() {
                *e = x()?;
            }
            let (iters, rhs) = (x()?, x()?);
            if !(iters >= 0.0 && rhs >= 0.0 && iters.fract() == 0.0 && rhs.fract() == 0.0) {
                return None;
            }
            nodes.push(Orbit {
                v_mean: v[0],
                force: v[1],
                slope: v[2],
                tangent: [v[3], v[4]],
                start: [v[5], v[6]],
                multipliers: [(v[7], v[8]), (v[9], v[10])],
                fast: (v[11], v[12]),
                iterations: iters as usize,
                rhs_evals: rhs as u64,
            });
        }
        if x().is_some() || !nodes.windows(2).all(|w| w[0].v_mean < w[1].v_mean) {
            return None;
        }
        Some(Table::of(nodes, stop.is_finite().then_some(stop), gaps))
    }
}

impl Table {
    /// The law with its rising branch cut at `f_esc` \[N\]: where the fast motion escapes from
    /// its low-velocity attractor at a frozen drive force below the law's peak (below the
    /// contact resonance the period-1 orbit there does not contract, and the attractor that
    /// holds the body is chaotic), the slow model must slip at `f_esc`, not at the fold. The
    /// nodes above `f_esc` between the rising and the falling branch are replaced by a flat
    /// stretch at `f_esc`, taken as valid; the rest is the law. `None` where the law never
    /// rises above `f_esc` or never falls back below it.
    pub fn capped(&self, f_esc: f64) -> Option<Table> {
        let n = &self.nodes;
        let i = n.iter().position(|o| o.force > f_esc)?;
        let j = i + n[i..].iter().position(|o| o.force < f_esc)?;
        if i == 0 {
            return None;
        }
        // Where each branch crosses f_esc, linearly between its nodes.
        let cross = |a: &Orbit, b: &Orbit| {
            a.v_mean + (f_esc - a.force) / (b.force - a.force) * (b.v_mean - a.v_mean)
        };
        let flat = |v: f64, like: &Orbit| Orbit {
            v_mean: v,
            force: f_esc,
            slope: 0.0,
            multipliers: [(0.0, 0.0); 2],
            fast: (0.0, 0.0),
            ..*like
        };
        let mut nodes: Vec<Orbit> = n[..i].to_vec();
        nodes.push(flat(cross(&n[i - 1], &n[i]), &n[i - 1]));
        nodes.push(flat(cross(&n[j - 1], &n[j]), &n[j]));
        nodes.extend_from_slice(&n[j..]);
        nodes.dedup_by(|b, a| b.v_mean <= a.v_mean);
        Some(Table::of(nodes, self.stopped_at, vec![]))
    }
}

/// The drive force \[N\] at which the body escapes from the low-velocity attractor of the fast
/// motion while the drive loads it, where that comes before the law's peak; `None` where every
/// orbit of the law's rising branch contracts (the slow model then slips at the law's own fold),
/// or the body holds up to the peak.
///
/// Below the contact resonance the period-1 orbit of the rising branch stops contracting before
/// the law's peak, and the attractor that holds the body there is not periodic: it lets the body
/// go at a lower force than the fold of `F_eff`. How much lower depends on how long the force
/// dwells near it (at 1500 Hz, v_a/v_d 0.4, a frozen force held 200 periods per level gave
/// 9.415 to 9.45 N by the levels' spacing), so the force here rises as the drive raises it
/// while the body sticks, at `k_d v_d`, from the last contracting orbit of the rising branch;
/// the escape is the first period whose mean velocity exceeds twice the peak's `V`.
/// [`Table::capped`] then gives the law the slow model slips by.
pub fn escape_force(p: &Params, table: &Table) -> Option<f64> {
    let n = &table.nodes;
    let peak = (0..n.len()).max_by(|&a, &b| n[a].force.total_cmp(&n[b].force))?;
    let first_bad = n[..=peak].iter().position(|o| !o.contracting())?;
    let lo = first_bad.checked_sub(1)?;
    let (f_lo, f_hi, v_peak) = (n[lo].force, n[peak].force, n[peak].v_mean);
    let rate = p.k_d * p.v_d;
    let period = 1.0 / p.f;
    let sh = Shooter::new(p, SHARED).ok()?;
    let sys = FastBase(Fast {
        p,
        force: f_lo,
        ramp: rate,
        v_a: sh.v_a,
        omega: sh.omega,
        scale_y: sh.scale_y,
        scale_p: sh.scale_p,
    });
    let opts = Options {
        rtol: 1e-7,
        atol: 1e-7,
        h_max: period / 8.0,
        ..Options::default()
    };
    // The ramp to the peak, whole periods (the orbit's phase 0 at each).
    let periods = ((f_hi - f_lo) / rate / period).ceil() as u64 + 1;
    let grid = OutputGrid {
        start: 0.0,
        step: period,
        count: periods + 1,
    };
    let mut y = [n[lo].start[0], n[lo].start[1], 0.0];
    let mut last_w = 0.0;
    let mut escaped = None;
    let rep = Solver::new(Method::Radau5).solve_until(
        &sys,
        Span::new(0.0, periods as f64 * period, grid),
        &mut y,
        &opts,
        |t, y| {
            let v = (y[2] - last_w) / period;
            last_w = y[2];
            if t > 0.0 && v > 2.0 * v_peak {
                escaped = Some(f_lo + rate * t);
                return false;
            }
            true
        },
    );
    (rep.status == Status::Success).then_some(escaped).flatten()
}

/// Upper end of the table [`TableStore::table`](crate::averaged::TableStore::table) builds for `p` \[m/s\]: 40 `v_d`, 10 `v_a` and 20
/// `v_s`, the largest. Beyond it the law is continued with the viscous slope `h_v` (the
/// vibration's share of the friction falls as `v_a/V`, and LuGre's Stribeck term has decayed
/// there). It does not depend on `k_d` or `h_d`, so one table serves every drive.
pub fn table_span(p: &Params) -> f64 {
    (40.0 * p.v_d).max(10.0 * p.v_a()).max(20.0 * p.v_s)
}

/// The options of [`TableStore::table`](crate::averaged::TableStore::table): the defaults but the one-period integration at `rtol`
/// 1e-5. At 3000 Hz, `v_a/v_d` = 0.4 (`k_d` = 11 700 N/m, `v_d` = 0.5 mm/s) the law agrees with
/// a table at `rtol` 1e-9 and `force_tol` 1e-5 N to 7e-4 N everywhere on `[0, table_span]` (33
/// nodes, as at 1e-6, for 0.7 of its work; 1.8e-4 N with the refinement's midpoints kept as
/// nodes, 65 of them); at `u0` = 5 nm, 2000 Hz it has the nodes of 1e-6 (30 and 44, before
/// the midpoints were kept). Newton stops at steps of `1e2 rtol` (scaled): at `1e3 rtol` noise
/// entered the slopes at 1e-5, the table grew to 83 to 98 nodes there, and its interpolant
/// stalled the slow model's integration.
pub const SHARED: AveragingOptions = AveragingOptions {
    rtol: 1e-5,
    max_newton: 30,
    force_tol: 1e-3,
    max_nodes: 400,
    validity_only: true,
};

fn reach(sh: &mut Shooter<'_>, from: &Orbit, v: f64) -> Result<Orbit, AveragingError> {
    // The start of the orbit at `to` from `o`, along the family's tangent.
    let guess = |o: &Orbit, to: f64| {
        let dv = to - o.v_mean;
        let t = finite_tangent(o);
        [
            o.start[0] + t[0] * dv,
            o.start[1] + t[1] * dv,
            o.force + o.slope * dv,
        ]
    };
    let mut base = *from;
    let mut err = None;
    for _ in 0..6 {
        match sh.orbit(v, guess(&base, v)) {
            Ok(o) => return Ok(o),
            Err(e) => {
                err = Some(e);
                // Half the stride, then on from there.
                let half = 0.5 * (base.v_mean + v);
                base = sh.orbit(half, guess(&base, half))?;
            }
        }
    }
    Err(err.expect("tried"))
}

/// The start `(v(0), s(0), F)` of the orbit at `v` between orbits `a` and `b`: the cubic
/// Hermite interpolant of their starts and forces on the family's tangents and slopes.
fn between(a: &Orbit, b: &Orbit, v: f64) -> [f64; 3] {
    let h = b.v_mean - a.v_mean;
    let s = (v - a.v_mean) / h;
    let (ta, tb) = (finite_tangent(a), finite_tangent(b));
    [
        cubic(h, s, [a.start[0], ta[0], b.start[0], tb[0]]),
        cubic(h, s, [a.start[1], ta[1], b.start[1], tb[1]]),
        hermite(a, b, v),
    ]
}

/// The orbit's tangent where finite, `(1, 0)` (the body's velocity follows `V`) where not.
fn finite_tangent(o: &Orbit) -> [f64; 2] {
    if o.tangent.iter().all(|x| x.is_finite()) {
        o.tangent
    } else {
        [1.0, 0.0]
    }
}

/// Cubic Hermite interpolation of the force between two orbits at `v`.
fn hermite(a: &Orbit, b: &Orbit, v: f64) -> f64 {
    let h = b.v_mean - a.v_mean;
    if h <= 0.0 {
        return a.force;
    }
    cubic(h, (v - a.v_mean) / h, [a.force, a.slope, b.force, b.slope])
}

/// The cubic Hermite interpolant at `s = (v − v_a)/h` of an interval `h` wide with values and
/// slopes `[x_a, x_a', x_b, x_b']` at its ends.
fn cubic(h: f64, s: f64, [x0, d0, x1, d1]: [f64; 4]) -> f64 {
    let (h00, h10, h01, h11) = (
        (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s),
        s * (1.0 - s) * (1.0 - s),
        s * s * (3.0 - 2.0 * s),
        s * s * (s - 1.0),
    );
    h00 * x0 + h10 * h * d0 + h01 * x1 + h11 * h * d1
}
