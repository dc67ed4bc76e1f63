//! The vibration averaged out: the effective friction law `F_eff(V)` of body and contact.
//!
//! Where the forcing period `1/f` is short against the stick-slip (the drive oscillator
//! `√(k_d/m)` runs 20 to 600 times slower than `ω = 2π f` in the paper's ranges), the drive force
//! hardly moves over one period. Freeze it at `F` and ask for the periodic orbit of the **body
//! and the contact together** (the contact resonance `√(k_t/m)/2π ≈ 1649 Hz` lies inside the
//! paper's band, so the body's mass belongs to the fast subsystem) whose mean velocity is `V`:
//!
//! ```text
//! m v' = F − F_F(v − u'(t), s),   s' = LuGre (docs/model.md),   u'(t) = v_a cos(ω t),
//! v(T) = v(0),   s(T) = s(0),   (1/T) ∫₀ᵀ v dt = V,                T = 1/f.
//! ```
//!
//! Over one period `m (v(T) − v(0)) = F T − ∫ F_F dt = 0`, so `F` is the period mean of the
//! friction force along the orbit: `F_eff(V) = F`. The unknowns `(v(0), s(0), F)` are found by
//! Newton shooting: one period of the variational equations (the 3 states `v`, `s`,
//! `w = ∫ v dt` and their 9 sensitivities to the unknowns) integrated by the project's Radau IIA
//! with error control on the sensitivities, then a 3 × 3 Newton step. The same Jacobian gives
//! the exact slope `dF_eff/dV` (implicit-function theorem) and the orbit's **fast Floquet
//! multipliers**, the eigenvalues of the monodromy matrix of `(v, s)` at fixed `F`: an orbit
//! whose multipliers approach −1 is about to period-double, where averaging is not valid.
//!
//! [`Table::build`] continues the orbit in `V` from 0 (where symmetry gives `F = 0`) to a
//! chosen `V_max`, with nodes added by bisection until cubic Hermite interpolation on the exact
//! slopes predicts every midpoint to the force tolerance (the midpoints found for that check are
//! nodes too). Each node keeps its orbit's state and multipliers, so a caller can tell where the
//! table may serve (a contracting period-1 orbit) and where it may not.
//!
//! References and checks: the rigid Coulomb limit `(2 F_c/π) asin(V/v_a)` (Littmann, Storck
//! and Wallaschek, Arch. Appl. Mech. 71 (2001) 549) for `u0 ≫ F_c/k_t`; the small-amplitude
//! creep slope `(π/2) F_s / v̂_r`, `v̂_r = v_a |mω² / (k_t − mω² + iωh_t)|`; and the settled
//! sliding force of full runs where vibration eliminates stick-slip (`tests/averaged.rs`).
//!
//! Rooms: [`orbit`] (the fast subsystem and its shooting), [`table`] (the law over `V`, its
//! lookups and text form), [`store`] (the tables a set of runs shares, as a value its owner hands
//! down). The slow model that uses the law and the policy that chooses it live in
//! [`crate::sim`].

pub mod orbit;
pub mod store;
pub mod table;

pub use self::orbit::{AveragingError, AveragingOptions, Orbit, Shooter};
pub use self::store::TableStore;
pub use self::table::{SHARED, Table, escape_force, table_span};
