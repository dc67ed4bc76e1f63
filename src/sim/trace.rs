//! Time traces of a run, shared by every tier.

use serde::{Deserialize, Serialize};

/// Time traces of a run, in SI units.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    /// Time \[s\].
    pub t: Vec<f64>,
    /// Drive force `F_d` \[N\].
    pub f_d: Vec<f64>,
    /// Drive force smoothed over one vibration period \[N\] (NaN during the first period).
    pub f_d_smooth: Vec<f64>,
    /// Body displacement `x_s` \[m\].
    pub x_s: Vec<f64>,
    /// Drive displacement `x_d = v_d t` \[m\].
    pub x_d: Vec<f64>,
    /// Contact deformation `s` \[m\].
    pub s: Vec<f64>,
    /// Relative velocity `v_r = v − u'(t)` [m/s].
    pub v_r: Vec<f64>,
    /// Body velocity `v` [m/s].
    pub v: Vec<f64>,
    /// Substrate displacement `u` \[m\].
    pub u: Vec<f64>,
}

impl Trace {
    /// Appends a sample of a model without the fast states (the averaged slow model, a hybrid
    /// run's period samples): the force also as the smoothed one, `s`, `v_r` and `u` NaN.
    pub(crate) fn push_slow(&mut self, t: f64, f: f64, x_s: f64, x_d: f64, v: f64) {
        self.t.push(t);
        self.f_d.push(f);
        self.f_d_smooth.push(f);
        self.x_s.push(x_s);
        self.x_d.push(x_d);
        self.s.push(f64::NAN);
        self.v_r.push(f64::NAN);
        self.v.push(v);
        self.u.push(f64::NAN);
    }

    /// Channel names, units and meanings, in file order.
    pub const CHANNELS: [(&'static str, &'static str, &'static str); 9] = [
        ("t", "s", "time"),
        ("F_d", "N", "drive force"),
        (
            "F_d_smooth",
            "N",
            "drive force, moving average over one vibration period",
        ),
        ("x_s", "m", "body (specimen) displacement"),
        ("x_d", "m", "drive displacement v_d t"),
        ("s", "m", "elastic deformation of the contact"),
        ("v_r", "m/s", "relative velocity of body and substrate"),
        ("v", "m/s", "body velocity"),
        ("u", "m", "substrate displacement"),
    ];

    /// The channels in [`Trace::CHANNELS`] order.
    pub fn columns(&self) -> [&[f64]; 9] {
        [
            &self.t,
            &self.f_d,
            &self.f_d_smooth,
            &self.x_s,
            &self.x_d,
            &self.s,
            &self.v_r,
            &self.v,
            &self.u,
        ]
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the trace is empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Keeps every second sample (the first, third, ...) of every channel.
    pub(crate) fn halve(&mut self) {
        for c in [
            &mut self.t,
            &mut self.f_d,
            &mut self.f_d_smooth,
            &mut self.x_s,
            &mut self.x_d,
            &mut self.s,
            &mut self.v_r,
            &mut self.v,
            &mut self.u,
        ] {
            let mut i = 0;
            c.retain(|_| {
                i += 1;
                i % 2 == 1
            });
        }
    }
}
