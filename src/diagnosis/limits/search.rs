//! The search of one effect's limit (the module docs of [`super`], "Searched by statistics,
//! judged in full"): the probe, the predictions from a signature scaled through the test's
//! draws, the confirmations in full, and the detected band's strong side.

use super::*;

/// How a limit was searched: the probe's prediction and every strength run in full to confirm
/// it (the JSON's `limits.effects[].search`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Search {
    /// The strength whose signature, simulated in full and scaled, made the first prediction
    /// (the ladder's first rung from the weak end).
    pub probe: f64,
    /// The strength that prediction puts at [`POWER`] (None: beyond the scan's strong end).
    pub predicted: Option<f64>,
    /// The noncentrality there: the sum of squares of the signature over the held-out rows,
    /// after the folds' refits, in the rows' standard errors.
    pub noncentrality: Option<f64>,
    /// Every strength run in full, in the order run: the probe, the confirmations, the ladder's
    /// rungs and the band's bisection where they were needed.
    pub runs: Vec<Confirmation>,
    /// The search ended at its budget ([`MAX_RUNS`]) before its bracket closed: the limit is
    /// the weakest strength confirmed, on the conservative side.
    pub at_budget: bool,
}

/// One strength of a [`Search`], run in full through the test.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Confirmation {
    /// The effect's parameter.
    pub value: f64,
    /// Noise draws ([`DRAWS`]).
    pub draws: usize,
    /// The draws on which the test fired (at least `POWER × draws`: detected).
    pub detected: usize,
    /// The share of rows whose runs failed (beyond [`MAX_FAILED`]: the strength is outside what
    /// the model can simulate and counts as not run).
    pub failed: f64,
    /// Its noncentrality as simulated: the sum of squares of its signature over the held-out
    /// rows after the folds' refits (0 where it failed).
    pub noncentrality: f64,
    /// The strength this run's own signature, scaled as the runs so far say the signature
    /// grows, puts at [`POWER`] (None: beyond the scan, or the run failed).
    pub predicts: Option<f64>,
}

/// A strength run in full: where on the scan, its power and what its signature predicts.
struct Run {
    u: f64,
    detected: usize,
    /// The share of rows whose runs failed (1 where no signature could be made).
    failed: f64,
    /// Its noncentrality as simulated (the sum of squares of its refitted signature over the
    /// held-out rows; 0 where it failed).
    lambda: f64,
    /// What its signature predicts: `u` at [`POWER`] and the noncentrality there.
    predicts: Option<(f64, f64)>,
}

impl Run {
    fn power(&self) -> f64 {
        self.detected as f64 / DRAWS as f64
    }

    fn ran(&self) -> bool {
        self.failed <= MAX_FAILED
    }

    fn fires(&self) -> bool {
        self.ran() && self.power() >= POWER
    }
}

/// One effect's scan: its strengths from the weak end (`u = 0`) to the strong end (`u = 1`),
/// the model in hand with the effect in the scanned form, and the campaign's pipeline and test.
struct Scanner<'r, 't, 'a> {
    s: &'r Scan,
    pipe: &'r Pipeline<'t, 'a>,
    pt: &'r PowerTest<'a>,
    model: Model,
    /// The recordings the effect leaves as the model in hand has them.
    alone: Vec<bool>,
    weak: f64,
    strong: f64,
    /// The parameter's range, to clamp to.
    range: (f64, f64),
    /// Where the effect vanishes (its neutral value, else the weak end): the origin of the
    /// strength its signature is proportional to.
    origin: f64,
    /// Rungs of the ladder ([`ladder_len`]).
    ladder: usize,
    /// The scan's resolution in `u`: the ladder's step halved [`BISECTIONS`] times.
    step: f64,
}

impl Scanner<'_, '_, '_> {
    /// The parameter at `u`.
    fn value(&self, u: f64) -> f64 {
        value_at(self.weak, self.strong, self.s.log, u).clamp(self.range.0, self.range.1)
    }

    /// The strength the signature at `v` is proportional to while it is small: the distance
    /// from the origin of `1/v` for a resonance (a filter's phase lag goes as `f/f_c`), of `v`
    /// itself otherwise.
    fn g(&self, v: f64) -> f64 {
        if self.s.stronger_below { 1.0 / v } else { v }
    }

    fn x(&self, u: f64) -> f64 {
        (self.g(self.value(u)) - self.g(self.origin)).abs()
    }

    /// The `u` at strength `x` (below 0 or above 1 outside the scan).
    fn u_of(&self, x: f64) -> f64 {
        let (g0, g1) = (self.g(self.origin), self.g(self.strong));
        let gv = g0 + x * (g1 - g0).signum();
        let v = if self.s.stronger_below { 1.0 / gv } else { gv };
        if self.s.log {
            if v.is_nan() || v <= 0.0 {
                return f64::NEG_INFINITY;
            }
            (v.ln() - self.weak.ln()) / (self.strong.ln() - self.weak.ln())
        } else {
            (v - self.weak) / (self.strong - self.weak)
        }
    }

    /// The effect at `u` simulated on every recording and run through the test, with what its
    /// signature predicts given the runs `before` it.
    fn run(&self, u: f64, before: &[Run]) -> Run {
        let mut m = self.model.clone();
        let sig = if m
            .effects
            .set_at(self.s.kind, self.s.param, self.value(u))
            .is_ok()
        {
            self.pipe.signature(&m, &self.alone)
        } else {
            None
        };
        let Some(sig) = sig else {
            return Run {
                u,
                detected: 0,
                failed: 1.0,
                lambda: 0.0,
                predicts: None,
            };
        };
        let un = self.pt.unabsorbed_draws(&sig);
        let detected = self.pt.detected(&sig, &un, 1.0);
        let (failed, lambda) = (sig.failed, un.noncentrality());
        let mut run = Run {
            u,
            detected,
            failed,
            lambda,
            predicts: None,
        };
        if run.ran() {
            let k = self.growth(&run, before);
            run.predicts = self.predict((u, k), &sig, &un);
        }
        run
    }

    /// How the signature grows with the strength `x` (`d ∝ x^k`), from the run `r` and the run
    /// before it nearest in `ln x`: `k = ln(λ_r/λ_o) / (2 ln(x_r/x_o))`, inside [0.5, 4]; 1
    /// (in proportion) where there is no such run. A filter's phase lag grows in proportion
    /// to `1/f_c`, a resonance's gain as its square, a saturating effect slower.
    fn growth(&self, r: &Run, before: &[Run]) -> f64 {
        let lx = |u: f64| self.x(u).ln();
        let usable = |o: &Run| o.ran() && o.lambda > 0.0 && lx(o.u).is_finite();
        if !usable(r) {
            return 1.0;
        }
        let Some(o) = before
            .iter()
            .filter(|o| usable(o) && (lx(o.u) - lx(r.u)).abs() > 1e-9)
            .min_by(|a, b| {
                (lx(a.u) - lx(r.u))
                    .abs()
                    .total_cmp(&(lx(b.u) - lx(r.u)).abs())
            })
        else {
            return 1.0;
        };
        let k = (r.lambda / o.lambda).ln() / (2.0 * (lx(r.u) - lx(o.u)));
        if k.is_finite() {
            k.clamp(0.5, 4.0)
        } else {
            1.0
        }
    }

    /// Where the signature `sig` simulated at `u`, scaled as the strength grows (`x^k`), reaches
    /// [`POWER`] on the same draws, and the noncentrality there: the smallest scale that does,
    /// bisected in its logarithm. None: no strength inside the scan does, or `u` is the origin.
    fn predict(&self, (u, k): (f64, f64), sig: &Signature, un: &Unabsorbed) -> Option<(f64, f64)> {
        let x = self.x(u);
        if !(x > 0.0 && x.is_finite()) {
            return None;
        }
        let need = (POWER * DRAWS as f64).ceil() as usize;
        let fires = |c: f64| self.pt.detected(sig, un, c) >= need;
        let c_hi = (self.x(1.0) / x).powf(k);
        if !fires(c_hi) {
            return None;
        }
        let c_lo = (self.x(0.0) / x).powf(k).max(c_hi * 1e-9);
        let c = if fires(c_lo) {
            c_lo
        } else {
            let (mut a, mut b) = (c_lo.ln(), c_hi.ln());
            for _ in 0..PREDICTION_BISECTIONS {
                let m = 0.5 * (a + b);
                if fires(m.exp()) { b = m } else { a = m }
            }
            b.exp()
        };
        Some((
            self.u_of(x * c.powf(1.0 / k)).clamp(0.0, 1.0),
            c * c * un.noncentrality(),
        ))
    }
}

/// What one scan's search ran and found.
struct Searched {
    runs: Vec<Run>,
    /// The weakest run that fired (index into `runs`).
    limit: Option<usize>,
    /// Ended at its budget before its bracket closed.
    at_budget: bool,
    /// Runs fail from this `u` on (infinity: nowhere).
    cap: f64,
}

impl Searched {
    fn has(&self, u: f64) -> bool {
        self.runs.iter().any(|r| r.u == u)
    }

    /// Keeps `run`: a failed one caps the search at its strength, the weakest that fires is
    /// the limit.
    fn push(&mut self, run: Run) {
        if !run.ran() {
            self.cap = self.cap.min(run.u);
        } else if run.fires() && self.limit.is_none_or(|i| run.u < self.runs[i].u) {
            self.limit = Some(self.runs.len());
        }
        self.runs.push(run);
    }

    /// The strongest `u` that ran without firing below the limit (below the cap without one);
    /// minus infinity where none did.
    fn quiet_below(&self) -> f64 {
        let hi = self.limit.map_or(self.cap, |i| self.runs[i].u);
        self.runs
            .iter()
            .filter(|r| r.ran() && !r.fires() && r.u < hi)
            .map(|r| r.u)
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

impl Scanner<'_, '_, '_> {
    /// The search for the weakest strength at which the test fires: the probe (the ladder's
    /// first rung) simulated in full, then, run after run, the strength the last run's
    /// signature predicts, kept inside the bracket the runs so far have confirmed
    /// ([`Scanner::next_u`]), until the bracket is one step wide or the last run fired where
    /// its own signature predicts (within a step).
    fn search(&self) -> Searched {
        let mut sr = Searched {
            runs: vec![],
            limit: None,
            at_budget: false,
            cap: f64::INFINITY,
        };
        let budget = MAX_RUNS + if self.s.resonance() { self.ladder } else { 0 };
        let mut next = Some(1.0 / self.ladder as f64);
        while let Some(u) = next {
            if sr.runs.len() >= budget {
                sr.at_budget = sr.limit.is_some();
                break;
            }
            sr.push(self.run(u, &sr.runs));
            next = self.next_u(&sr);
        }
        sr
    }

    /// The next strength to run, or None where the search is done. A quiet run's prediction
    /// is taken a step further (a signature that grows slower than in proportion, as most
    /// saturate, puts the power within reach too early); where it points no further than a
    /// step past what ran quiet, the search steps outward, doubling its stride on every such
    /// run. Inside a bracket, a prediction that leaves it gives way to the bracket's middle.
    fn next_u(&self, sr: &Searched) -> Option<f64> {
        let last = sr.runs.last()?;
        let step = self.step;
        let lo = sr.quiet_below();
        let fresh = |u: f64| (!sr.has(u)).then_some(u);
        let predicted = last
            .predicts
            .map(|p| if last.fires() { p.0 } else { p.0 + step });
        let Some(i) = sr.limit else {
            if !last.ran() {
                let mid = 0.5 * (lo + sr.cap);
                return (lo.is_finite() && sr.cap - lo > step)
                    .then_some(mid)
                    .and_then(fresh);
            }
            let lo = if lo.is_finite() { lo } else { last.u };
            let stalls = sr
                .runs
                .iter()
                .filter(|r| r.ran() && !r.fires() && r.predicts.is_none_or(|p| p.0 <= r.u + step))
                .count();
            let mut u = predicted
                .filter(|&p| p > lo + step)
                .unwrap_or(lo + step * 2f64.powi(stalls as i32))
                .min(1.0);
            if u >= sr.cap {
                u = 0.5 * (lo + sr.cap);
            }
            return fresh(u).or_else(|| self.next_rung(sr));
        };
        let h = sr.runs[i].u;
        // The last run fired where its own signature says the power is reached: done.
        if std::ptr::eq(last, &sr.runs[i]) && predicted.is_some_and(|p| p >= h - step) {
            return None;
        }
        let floor = if lo.is_finite() { lo } else { 0.0 };
        if h - floor <= step {
            // Closed, unless the weak end itself has not run (detected everywhere?).
            return (!lo.is_finite()).then_some(0.0).and_then(fresh);
        }
        let inside = |u: f64| u <= h - step && (u >= floor + step || !lo.is_finite());
        let u = predicted
            .filter(|&p| inside(p))
            .unwrap_or(0.5 * (floor + h));
        fresh(u).or_else(|| fresh(0.5 * (floor + h)))
    }

    /// A resonance's next rung of the ladder not run yet, from the weak end: where neither
    /// the prediction nor the strong end fired, the band it may show in lies between.
    fn next_rung(&self, sr: &Searched) -> Option<f64> {
        if !self.s.resonance() {
            return None;
        }
        (1..=self.ladder)
            .map(|k| k as f64 / self.ladder as f64)
            .find(|&u| u < sr.cap && !sr.has(u))
    }

    /// The detected band's strong side, once a limit is found: the strong end run; where it
    /// does not fire, every rung of the ladder stronger than the limit, the rungs that do not
    /// fire are holes and the band's end is bisected below the first of them
    /// ([`BISECTIONS`]). Where the strong end fires, every strength between is taken to.
    fn band(&self, sr: &mut Searched) -> (Vec<f64>, Option<f64>) {
        let Some(i) = sr.limit else {
            return (vec![], None);
        };
        let h = sr.runs[i].u;
        let ensure = |sr: &mut Searched, u: f64| {
            if u < sr.cap && !sr.has(u) {
                sr.push(self.run(u, &sr.runs));
            }
        };
        ensure(sr, 1.0);
        if sr.runs.iter().any(|r| r.u == 1.0 && r.fires()) {
            return (vec![], None);
        }
        for k in 1..=self.ladder {
            let u = k as f64 / self.ladder as f64;
            if u > h {
                ensure(sr, u);
            }
        }
        let mut quiet: Vec<f64> = sr
            .runs
            .iter()
            .filter(|r| r.u > h && r.ran() && !r.fires())
            .map(|r| r.u)
            .collect();
        quiet.sort_by(f64::total_cmp);
        let Some(&first) = quiet.first() else {
            return (vec![], None);
        };
        let holes = quiet.iter().map(|&u| self.value(u)).collect();
        let mut a = sr
            .runs
            .iter()
            .filter(|r| r.u < first && r.fires())
            .map(|r| r.u)
            .fold(h, f64::max);
        let mut b = first;
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (a + b);
            let run = self.run(mid, &sr.runs);
            let fires = run.fires();
            sr.push(run);
            if fires { a = mid } else { b = mid }
        }
        (holes, Some(self.value(a)))
    }

    /// How the search went, for the JSON.
    fn record(&self, sr: &Searched) -> Search {
        let probe = &sr.runs[0];
        Search {
            probe: self.value(probe.u),
            predicted: probe.predicts.map(|p| self.value(p.0)),
            noncentrality: probe.predicts.map(|p| p.1),
            runs: sr
                .runs
                .iter()
                .map(|r| Confirmation {
                    value: self.value(r.u),
                    draws: DRAWS,
                    detected: r.detected,
                    failed: r.failed,
                    noncentrality: r.lambda,
                    predicts: r.predicts.map(|p| self.value(p.0)),
                })
                .collect(),
            at_budget: sr.at_budget,
        }
    }
}

/// One effect's scan: the limit searched ([`Scanner::search`]), the detected band's strong
/// side ([`Scanner::band`]), and its statement.
pub(super) fn scan_limit(
    s: &Scan,
    all: &Target,
    against: &FitResult,
    pipe: &Pipeline<'_, '_>,
    pt: &PowerTest<'_>,
) -> Limit {
    let sc = scanner(s, all, against, pipe, pt);
    let mut sr = sc.search();
    let (holes, band_end) = sc.band(&mut sr);
    let limit_run = sr.limit.map(|i| &sr.runs[i]);
    let reached = if sr.cap.is_finite() {
        sr.runs
            .iter()
            .filter(|r| r.ran())
            .map(|r| r.u)
            .fold(0.0, f64::max)
    } else {
        1.0
    };
    // The power at the limit, else at the strongest strength run.
    let power = limit_run.map_or_else(
        || {
            sr.runs
                .iter()
                .filter(|r| r.ran())
                .max_by(|a, b| a.u.total_cmp(&b.u))
                .map_or(0.0, Run::power)
        },
        Run::power,
    );
    let p = s.param.of(s.kind);
    let found = Found {
        weak: sc.weak,
        strong: sc.value(reached),
        limit: limit_run.map(|r| sc.value(r.u)),
        band_end,
        everywhere: limit_run.is_some_and(|r| r.u == 0.0),
        holes: &holes,
        power,
        reached,
    };
    let (stronger, statement) = statement(s, p.unit, &found);
    let (limit, strong_end) = (found.limit, found.strong);
    Limit {
        effect: s.kind.info().name,
        search: sc.record(&sr),
        holes,
        band_end,
        param: s.param_name(),
        unit: p.unit,
        label: s.label,
        form: s
            .fixed_named()
            .map(|(q, v)| format!("{q} = {v}"))
            .collect::<Vec<_>>()
            .join(", "),
        form_name: s.form_name(),
        stronger,
        limit,
        power,
        weak_end: sc.weak,
        strong_end,
        statement,
    }
}

/// The scanner of `s`: the model in hand with the effect's form, the scan's ends inside the
/// plausible range, its origin, ladder and step.
fn scanner<'r, 't, 'a>(
    s: &'r Scan,
    all: &Target,
    against: &FitResult,
    pipe: &'r Pipeline<'t, 'a>,
    pt: &'r PowerTest<'a>,
) -> Scanner<'r, 't, 'a> {
    let p = s.param.of(s.kind);
    let (lo, hi) = all.bounds.range(s.kind, s.param);
    let (lo, hi) = (lo.max(p.min), hi.min(p.max));
    let neutral = neutral(s.kind, s.param);
    let at_end = if s.stronger_below { hi } else { lo };
    let weak = s.weak.unwrap_or(neutral.unwrap_or(at_end)).clamp(lo, hi);
    let weak = if s.log && weak <= 0.0 {
        hi * 1e-4
    } else {
        weak
    };
    let strong = s.strong.unwrap_or(if s.stronger_below { lo } else { hi });
    let mut model = against.model.clone();
    for &(q, v) in s.fixed {
        // The form's values are inside the library's bounds by construction.
        let _ = model.effects.set_at(s.kind, q, v);
    }
    // An effect that acts through the vibration leaves a recording without any (its
    // amplitude 0) as the model in hand has it: not simulated again.
    let alone = all
        .recs
        .iter()
        .map(|r| s.kind.vibration_only() && r.params.u0 == 0.0)
        .collect();
    let ladder = ladder_len(s, weak, strong);
    Scanner {
        s,
        pipe,
        pt,
        model,
        alone,
        weak,
        strong,
        range: (lo.min(hi), lo.max(hi)),
        origin: neutral.filter(|v| v.is_finite()).unwrap_or(weak),
        ladder,
        step: 1.0 / (ladder as f64 * 2f64.powi(BISECTIONS as i32)),
    }
}

/// Rungs of a scan's ladder: [`LADDER`], more for a resonance so that neighbouring rungs are
/// at most [`RESONANCE_STEP`] apart.
fn ladder_len(s: &Scan, weak: f64, strong: f64) -> usize {
    if s.resonance() && weak > 0.0 && strong > 0.0 {
        let octaves = (weak / strong).ln() / RESONANCE_STEP.ln();
        LADDER.max(octaves.ceil() as usize)
    } else {
        LADDER
    }
}
