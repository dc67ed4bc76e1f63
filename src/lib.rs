//! stickslip: where tangential substrate vibration suppresses stick-slip friction.
//!
//! The library simulates the test rig of the paper (a body dragged through a soft drive over a
//! tangentially vibrating substrate, LuGre friction; equations in [`model`]) with stiff adaptive
//! integrators ([`ode`]), measures the stick-slip amplitude, the reduction coefficient `r` and the
//! mean drive force ([`measures`], [`sim`]).
#![recursion_limit = "256"]
pub mod app;
pub mod averaged;
pub mod bench;
pub mod campaign;
pub mod cli;
pub mod config;
pub mod console;
pub mod cycle;
pub mod diagnosis;
pub mod interrupt;
pub mod measures;
pub mod model;
pub mod nullable;
pub mod ode;
pub mod output;
pub mod planning;
pub mod plot;
pub mod progress;
pub mod sim;
pub mod slurm;
pub mod sweep;
