//! The energy switches of a plan as text: by class and band of energy step, and the small upward
//! steps with what each costs (`simulate`'s summary, `validate`, `resequence`).

use std::fmt::Write;

use arcsim_sequencer::{SwitchGroup, Switching};

/// Small upward steps listed one per line before "+N more".
const LISTED: usize = 10;

fn band_text(g: &SwitchGroup) -> String {
    match g.step_to_mev {
        Some(hi) if g.step_from_mev == 0.0 => format!("< {hi} MeV"),
        Some(hi) => format!("{}–{hi} MeV", g.step_from_mev),
        None => format!("≥ {} MeV", g.step_from_mev),
    }
}

fn row(s: &mut String, class: &str, band: &str, g: &SwitchGroup) {
    let opt = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |v| format!("{v:.2}"));
    let _ = writeln!(
        s,
        "  {class:<10}  {band:<12} {:>6}  {:>9.2}  {:>9}  {:>8}",
        g.count,
        g.elst_s,
        opt(g.time_s),
        opt(g.lost_s)
    );
}

/// The switching table of a delivery of `plan` on `machine` (empty if the plan does not resolve,
/// which a simulated plan does).
pub fn of_delivery(
    plan: &arcsim_plan::ArcPlan,
    machine: &arcsim_plan::Machine,
    d: &arcsim_sequencer::Delivery,
) -> String {
    arcsim_app::switching_of(plan, machine, d).map_or_else(String::new, |sw| lines(&sw))
}

/// The table of switches (a class's total, then its bands) and the small upward steps.
pub fn lines(sw: &Switching) -> String {
    let mut s = String::new();
    if sw.by_class.is_empty() {
        return s;
    }
    let _ = writeln!(
        s,
        "energy switches by class and step (ELST: the switching times; taken: the transitions' durations):"
    );
    let _ = writeln!(
        s,
        "  switch      step          count   ELST (s)  taken (s)  lost (s)"
    );
    for class in &sw.by_class {
        let name = class.switch.name();
        let bands: Vec<_> = sw
            .by_step
            .iter()
            .filter(|g| g.switch == class.switch)
            .collect();
        match bands[..] {
            [one] => row(&mut s, name, &band_text(one), class),
            _ => {
                row(&mut s, name, "all", class);
                for g in bands {
                    row(&mut s, "", &band_text(g), g);
                }
            }
        }
    }
    if sw.small_upward.is_empty() {
        let _ = writeln!(
            s,
            "no upward step below {} MeV",
            sw.small_upward_threshold_mev
        );
        return s;
    }
    let _ = writeln!(
        s,
        "{} below {} MeV: {:.2} s of ELST beyond the quicker switch each could be (rounding in the plan?):",
        crate::count(sw.small_upward.len(), "upward step"),
        sw.small_upward_threshold_mev,
        sw.small_upward_cost_s
    );
    let _ = writeln!(
        s,
        "  arc  control point   angle (deg)        energy (MeV)       step (MeV)  ELST (s)  cost (s)"
    );
    for st in sw.small_upward.iter().take(LISTED) {
        let _ = writeln!(
            s,
            "  {:<3}  {:>5} → {:<5}  {:7.2} → {:<7.2}  {:7.2} → {:<7.2}  {:10.2}  {:8.2}  {:8.2}",
            st.arc,
            st.from_control_point,
            st.to_control_point,
            crate::gantry_deg(st.from_angle_deg),
            crate::gantry_deg(st.to_angle_deg),
            st.from_energy_mev,
            st.to_energy_mev,
            st.step_mev,
            st.elst_s,
            st.cost_s
        );
    }
    if sw.small_upward.len() > LISTED {
        let _ = writeln!(s, "  +{} more", sw.small_upward.len() - LISTED);
    }
    s
}
