//! The text `simulate` prints: the summary of a delivery, its certificate and Monte Carlo lines.

use std::fmt::Write as _;

use arcsim_sequencer::{Certificate, Delivery, Limiter, Margins, Motion};

/// `x` with `decimals` decimals, right-aligned in `width` characters; a zero is never signed
/// ("-0.00" is written "0.00").
fn fixed(x: f64, decimals: usize, width: usize) -> String {
    let text = arcsim_plan::without_zero_sign(format!("{x:.decimals$}"));
    format!("{text:>width$}")
}

fn min_sec(t: f64) -> String {
    let m = (t / 60.0).floor();
    format!("{}:{:04.1}", m as u64, t - 60.0 * m)
}

fn limiter_name(l: Limiter) -> &'static str {
    match l {
        Limiter::Elst => "ELST",
        Limiter::Speed => "V",
        Limiter::Accel => "A",
        Limiter::Jerk => "J",
        Limiter::None => "-",
    }
}

/// The readable summary printed on standard output.
pub fn summary(d: &Delivery, plan: &str, machine: &str) -> String {
    let mut s = String::new();
    heading(&mut s, d, plan, machine);
    time_breakdown(&mut s, d);
    motion_notes(&mut s, d);
    if let Some(m) = d.margins {
        tightest_margins(&mut s, &m);
    }
    where_lost(&mut s, d);
    speed_violations(&mut s, d);
    s
}

/// The plan, machine, schedule and motion, and the counts of layers and transitions.
fn heading(s: &mut String, d: &Delivery, plan: &str, machine: &str) {
    let _ = writeln!(
        s,
        "plan {plan} on {machine}, schedule {}, motion {}{}",
        d.schedule.name(),
        d.motion.name(),
        if d.motion.speed_changes_during_beam() {
            format!(" (arc ends {})", d.arc_ends.name())
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        s,
        "{}, {}",
        crate::count(d.layers.len(), "layer"),
        crate::count(d.transitions.len(), "transition")
    );
}

/// The total delivery time and its parts, each with its share of the total.
fn time_breakdown(s: &mut String, d: &Delivery) {
    let b = d.breakdown;
    let pct = |x: f64| {
        if d.total_s > 0.0 {
            100.0 * x / d.total_s
        } else {
            0.0
        }
    };
    let _ = writeln!(
        s,
        "total delivery time  {:9.2} s  ({})",
        d.total_s,
        min_sec(d.total_s)
    );
    let _ = writeln!(
        s,
        "  beam on            {} s  {} %",
        fixed(b.beam_on_s, 2, 9),
        fixed(pct(b.beam_on_s), 1, 5)
    );
    if b.scanning_s + b.burst_switching_s + b.spill_waiting_s > 0.0 {
        let _ = writeln!(
            s,
            "    spot irradiation {} s  {} %",
            fixed(b.spot_irradiation_s, 2, 9),
            fixed(pct(b.spot_irradiation_s), 1, 5)
        );
        let _ = writeln!(
            s,
            "    between spots    {} s  {} %  (scanning, settling, layer overhead)",
            fixed(b.scanning_s, 2, 9),
            fixed(pct(b.scanning_s), 1, 5)
        );
    }
    if b.burst_switching_s > 0.0 {
        let _ = writeln!(
            s,
            "    burst switching  {} s  {} %  (pauses between a layer's bursts)",
            fixed(b.burst_switching_s, 2, 9),
            fixed(pct(b.burst_switching_s), 1, 5)
        );
    }
    if b.spill_waiting_s > 0.0 {
        let _ = writeln!(
            s,
            "    spill waiting    {} s  {} %  (beam off, waiting for the next spill)",
            fixed(b.spill_waiting_s, 2, 9),
            fixed(pct(b.spill_waiting_s), 1, 5)
        );
    }
    let _ = writeln!(
        s,
        "  energy switching   {} s  {} %",
        fixed(b.energy_switching_s, 2, 9),
        fixed(pct(b.energy_switching_s), 1, 5)
    );
    let _ = writeln!(
        s,
        "  lost (gantry)      {} s  {} %",
        fixed(b.lost_s, 2, 9),
        fixed(pct(b.lost_s), 1, 5)
    );
}

/// After the heading's first line: the controller the number comes from and where that came
/// from, and how to see each other model as a what-if (the constant-speed total comes with every
/// other model, as its seed or baseline; the others are asked for, as free motion costs seconds).
pub fn insert_controller_lines(text: &mut String, used: &arcsim_app::ControllerUsed, d: &Delivery) {
    let mut lines = format!("{}\n", used.line());
    for m in Motion::ALL {
        let shown = m == d.motion || (m == Motion::Constant && d.constant_speed_total_s.is_some());
        if !shown {
            lines.push_str(&format!(
                "what-if: {} with --motion {}\n",
                m.describe(),
                m.name()
            ));
        }
    }
    let at = text.find('\n').map_or(text.len(), |i| i + 1);
    text.insert_str(at, &lines);
}

/// The servo period, what the model saves or costs against constant speed per layer, and what
/// limits the transitions.
fn motion_notes(s: &mut String, d: &Delivery) {
    if let Some(ts) = d.servo_period_s {
        let _ = writeln!(
            s,
            "transitions last whole numbers of a {:.3} ms servo period (limits kept)",
            1e3 * ts
        );
    }
    if let Some(c) = d.constant_speed_total_s {
        let saved = c - d.total_s;
        let (verb, by) = if saved >= 0.0 {
            ("saves", saved)
        } else {
            ("costs", -saved)
        };
        let _ = writeln!(
            s,
            "{} {verb} {} s ({} %) against constant speed per layer ({c:.2} s)",
            d.motion.short(),
            fixed(by, 2, 0),
            fixed(if c > 0.0 { 100.0 * by / c } else { 0.0 }, 1, 0)
        );
    }
    let c = d.limiter_counts;
    let _ = writeln!(
        s,
        "transitions limited by: ELST {}, V {}, A {}, J {}, none {}",
        c.elst, c.speed, c.accel, c.jerk, c.none
    );
}

/// How close the delivery comes to each limit, and where.
fn tightest_margins(s: &mut String, m: &Margins) {
    let _ = writeln!(s, "tightest margins:");
    let _ = writeln!(
        s,
        "  speed        {:6.1} % of V     at t = {:8.2} s (layer {})",
        100.0 * m.speed_use.value,
        m.speed_use.t_s,
        m.speed_use.layer
    );
    let _ = writeln!(
        s,
        "  acceleration {:6.1} % of A/D   at t = {:8.2} s (layer {})",
        100.0 * m.accel_use.value,
        m.accel_use.t_s,
        m.accel_use.layer
    );
    let _ = writeln!(
        s,
        "  jerk         {:6.1} % of J     at t = {:8.2} s (layer {})",
        100.0 * m.jerk_use.value,
        m.jerk_use.t_s,
        m.jerk_use.layer
    );
    let _ = writeln!(
        s,
        "  window slack {:8.4} deg      at t = {:8.2} s (layer {})",
        m.window_slack_deg.value, m.window_slack_deg.t_s, m.window_slack_deg.layer
    );
    if m.elst_slack_s.value.is_finite() {
        let _ = writeln!(
            s,
            "  ELST slack   {:8.4} s        at t = {:8.2} s (layer {})",
            m.elst_slack_s.value.max(0.0),
            m.elst_slack_s.t_s,
            m.elst_slack_s.layer
        );
    }
}

/// The prescribed speeds that cannot be delivered, and the speeds used instead.
fn speed_violations(s: &mut String, d: &Delivery) {
    if !d.violations.is_empty() {
        let _ = writeln!(
            s,
            "{} prescribed speeds cannot be delivered (corrected speeds used above):",
            d.violations.len()
        );
        for v in &d.violations {
            let _ = writeln!(
                s,
                "  arc {}, control point {} (layer {}): {:.4} deg/s → {:.4} deg/s: {}",
                v.arc,
                v.control_point,
                v.layer,
                v.prescribed_deg_per_s,
                v.corrected_deg_per_s,
                v.reason
            );
        }
    }
}

/// Angle ranges as "10–30, 44–52 deg" (gantry angles, in [0, 360)), at most four, then
/// "+N more".
fn ranges_text(r: &[[f64; 2]]) -> String {
    let mut parts: Vec<String> = r
        .iter()
        .take(4)
        .map(|&[a, b]| {
            let (a, b) = (crate::gantry_deg(a), crate::gantry_deg(b));
            if (b - a).abs() < 1e-9 {
                format!("{a:.1}")
            } else {
                format!("{a:.1}–{b:.1}")
            }
        })
        .collect();
    if r.len() > 4 {
        parts.push(format!("+{} more", r.len() - 4));
    }
    parts.join(", ")
}

/// "Where the time is lost": lost time by cause and place, then the costliest transitions,
/// located by arc, control point and angle.
fn where_lost(s: &mut String, d: &Delivery) {
    let lt = &d.lost_time;
    if lt.count == 0 {
        let _ = writeln!(s, "no time lost: every transition lasts just its ELST");
        return;
    }
    let _ = writeln!(
        s,
        "where the time is lost: {:.2} s in {} of {} transitions (time beyond the ELST)",
        lt.total_s,
        lt.count,
        d.transitions.len()
    );
    let _ = writeln!(
        s,
        "  limit  switch      layers apart         count  lost (s)  each (s)  angles (deg)"
    );
    for g in lt.groups.iter().take(8) {
        let _ = writeln!(
            s,
            "  {:<5}  {:<10}  {:<19} {:>6}  {:8.2}  {:8.2}  {}",
            limiter_name(g.limited_by),
            g.switch.name(),
            g.gap.name(),
            g.count,
            g.lost_s,
            g.mean_lost_s,
            ranges_text(&g.angle_ranges_deg)
        );
    }
    if lt.groups.len() > 8 {
        let rest: f64 = lt.groups[8..].iter().map(|g| g.lost_s).sum();
        let _ = writeln!(s, "  … {} more causes, {rest:.2} s", lt.groups.len() - 8);
    }
    let _ = writeln!(s, "{} most costly transitions:", lt.costliest.len());
    let _ = writeln!(
        s,
        "  arc  control point   angle (deg)        start (s)  duration (s)  ELST (s)  lost (s)  switch  limit"
    );
    for c in &lt.costliest {
        let tr = &d.transitions[c.transition];
        let arc = if c.from_arc == c.to_arc {
            format!("{}", c.from_arc)
        } else {
            format!("{}→{}", c.from_arc, c.to_arc)
        };
        let _ = writeln!(
            s,
            "  {:<3}  {:>5} → {:<5}  {:7.2} → {:<7.2}  {:9.2}  {:12.3}  {:8.2}  {:8.3}  {:<6}  {}",
            arc,
            c.from_control_point,
            c.to_control_point,
            crate::gantry_deg(c.from_angle_deg),
            crate::gantry_deg(c.to_angle_deg),
            tr.t_start_s,
            c.duration_s,
            c.elst_s,
            c.lost_s,
            c.switch.name(),
            limiter_name(c.limited_by)
        );
    }
}

/// The certificate's lines of the summary.
pub(super) fn certificate_lines(c: &Certificate, total_s: f64, motion: Motion) -> String {
    let pct = if total_s > 0.0 {
        100.0 * c.gap_s / total_s
    } else {
        0.0
    };
    // One speed per arc is a constant-speed delivery (its cruises held): the constant-speed
    // bound holds for it too.
    let what = if motion.speed_changes_during_beam() {
        "no free motion is faster; a loose bound"
    } else {
        "no constant-speed schedule is faster"
    };
    format!(
        "lower bound          {:9.2} s  ({what})\n\
         gap                  {:9.3} s  {:6.3} %\n",
        c.lower_bound_s, c.gap_s, pct
    )
}

pub(super) fn monte_carlo_lines(m: &arcsim_evaluator::MachineMonteCarlo) -> String {
    let mc = &m.both;
    let sp = &mc.spread;
    let mut s = format!(
        "Monte Carlo, {} draws (seed {}; sd of ELST up {:.4} s, down {:.4} s, same {:.4} s, beam-on {:.2} %{}):\n  \
         total P5 {:.2} s, P50 {:.2} s, P95 {:.2} s (mean {:.2} s, sd {:.2} s)\n",
        mc.draws,
        mc.seed,
        sp.elst_up_sd_s,
        sp.elst_down_sd_s,
        sp.elst_same_sd_s,
        100.0 * sp.beam_time_sd_fraction,
        if m.uncertainty.is_some() {
            "; and the fitted values' uncertainty, one draw per delivery"
        } else {
            ""
        },
        mc.p5_s,
        mc.p50_s,
        mc.p95_s,
        mc.mean_s,
        mc.sd_s
    );
    if let (Some(a), Some(b)) = (m.spreads_only_sd_s, m.parameters_only_sd_s) {
        s.push_str(&format!(
            "  sd from the timing spreads alone {a:.2} s, from the fitted values' uncertainty alone {b:.2} s: the {} dominate\n",
            if m.dominant == "parameters" { "fitted values" } else { "timing spreads" }
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::fixed;

    #[test]
    fn summary_numbers_never_show_a_signed_zero() {
        assert_eq!(fixed(-0.0, 2, 9), "     0.00");
        assert_eq!(fixed(-1e-12, 1, 5), "  0.0");
        assert_eq!(fixed(-0.5, 2, 0), "-0.50");
        assert_eq!(fixed(12.345, 2, 9), "    12.35");
    }
}
