use stickslip::campaign::Campaign;
use stickslip::campaign::fit::{self, FitOptions, Model, Target};
use stickslip::model::EffectKind;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let c = Campaign::load(std::path::Path::new(&a[1])).unwrap();
    let t = Target::new(c.recordings.iter().collect());
    let fo = FitOptions {
        final_jacobian: true,
        ..FitOptions::default()
    };
    let base = fit::fit(&t, &Model::default(), &[], fo);
    println!("base {:.2} {:?}", base.gap, base.model);
    let k = EffectKind::Viscous;
    let st = fit::starts(&t, &base, k);
    println!(
        "scan start {:?} gap {:.2}",
        st.effects,
        fit::evaluate(&t, &st)
    );
    let so = FitOptions {
        max_iter: 5,
        rel_tol: 0.01,
        reach: 0.9 * base.gap,
        final_jacobian: false,
        ..FitOptions::default()
    };
    let first = fit::prepare(&t, &st, &[k]);
    let s = fit::fit_extending(&t, first, &base.jacobian, so);
    println!(
        "screen gap {:.2} evals {} model {:?}",
        s.gap, s.evaluations, s.model
    );
    let so = FitOptions {
        max_iter: 5,
        rel_tol: 0.01,
        final_jacobian: false,
        ..FitOptions::default()
    };
    let first = fit::prepare(&t, &st, &[k]);
    let s = fit::fit_from(&t, first, so);
    println!(
        "screen w/o reach gap {:.2} evals {} model {:?}",
        s.gap, s.evaluations, s.model
    );
}
