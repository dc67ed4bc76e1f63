use stickslip::campaign::Campaign;
use stickslip::campaign::fit::{self, Model, Target};
use stickslip::model::EffectKind;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let c = Campaign::load(std::path::Path::new(&a[1])).unwrap();
    let t = Target::new(c.recordings.iter().collect());
    let base = Model {
        f_s: 9.3991,
        f_c: 8.7119,
        v_s: 1.596e-4,
        h_d: 0.25,
        ..Model::default()
    };
    println!("base {:.2}", fit::evaluate(&t, &base));
    for (fs, fc, vs, hd) in [
        (11.5, 8.7, 1.6e-4, 0.25),
        (11.5, 8.3, 1.6e-4, 0.25),
        (11.5, 8.7, 3.5e-4, 0.25),
        (11.5, 8.7, 1.6e-4, 0.0),
        (11.5, 8.3, 3.5e-4, 0.25),
        (10.5, 8.3, 3.5e-4, 0.25),
        (9.4, 8.7, 3.5e-4, 0.25),
    ] {
        for (hv, n) in [(40.0, 2.0)] {
            let mut m = base.clone();
            m.f_s = fs;
            m.f_c = fc;
            m.v_s = vs;
            m.h_d = hd;
            m.effects.enable(EffectKind::Viscous);
            m.effects.set(EffectKind::Viscous, "h_v", hv).unwrap();
            m.effects.set(EffectKind::Viscous, "exponent", n).unwrap();
            println!(
                "F_s {fs} F_c {fc} v_s {vs} h_d {hd} h_v {hv} n {n}: {:.2}",
                fit::evaluate(&t, &m)
            );
        }
    }
}
