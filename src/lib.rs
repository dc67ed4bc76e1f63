//! stickslip: where tangential substrate vibration suppresses stick-slip friction.
pub mod ode;
