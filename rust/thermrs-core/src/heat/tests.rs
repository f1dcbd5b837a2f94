use super::calibration::{saturating_ratio, table4_rises, TABLE4};
use super::*;
use crate::error::KeyError;

fn node(name: &str) -> NodeParams {
    kr15_paper_nodes()
        .into_iter()
        .find(|n| n.name == name)
        .unwrap()
}

/// The paper's protocol with 1-minute steps: Run 1 (30 %, 900 min), 600 min idle, Run 2
/// (75 %, 900 min), Run 3 (10 %, 900 min). Returns (t_s, speed, ambient) and the sample
/// indices of the five Table 4 instants (Run 1 start/end, Run 2 start/end = Run 3 start,
/// Run 3 end).
fn paper_protocol() -> (Vec<f64>, Vec<Option<f64>>, Vec<f64>, [usize; 5]) {
    let segments: [(Option<f64>, usize); 4] = [
        (Some(0.30), 900),
        (None, 600),
        (Some(0.75), 900),
        (Some(0.10), 900),
    ];
    let mut speed = Vec::new();
    for (s, minutes) in segments {
        speed.extend(std::iter::repeat_n(s, minutes));
    }
    speed.push(None); // after the last sample: unused
    let n = speed.len();
    let t_s: Vec<f64> = (0..n).map(|k| k as f64 * 60.0).collect();
    let ambient = vec![KR15_PAPER_AMBIENT_C; n];
    (t_s, speed, ambient, [0, 900, 1500, 2400, 3300])
}

#[test]
fn reproduces_table4_within_0_05_c() {
    let (t_s, speed, ambient, idx) = paper_protocol();
    for link in &TABLE4 {
        let n = node(link.name);
        let t = simulate(&n, &t_s, &speed, &ambient, link.run1.0).unwrap();
        let want = [
            link.run1.0,
            link.run1.1,
            link.run2.0,
            link.run2.1,
            link.run3_end,
        ];
        for (i, w) in idx.iter().zip(want) {
            let got = t[*i];
            assert!(
                (got - w).abs() < 0.05,
                "{} at minute {i}: {got:.4} vs Table 4 {w}",
                link.name
            );
            // The calibration is analytic, so in fact it is exact to rounding.
            assert!((got - w).abs() < 1e-9, "{} at {i}: {got} vs {w}", link.name);
        }
    }
}

/// The module documentation's calibration table, derived here by hand from Table 4 (the
/// printed temperatures and the protocol's 600 and 900 minutes), not copied from the code's
/// output: τ, q, the three steady rises and ρ in closed form; the printed s0 must solve the
/// ratio equation g(s0) = ρ (step 3) to its printed digits, and r_span, r0 and the rises at
/// 0/50/100 % then follow in closed form. The calibrated nodes must agree with the derivation.
#[test]
fn documented_calibration_numbers_derive_from_table4() {
    let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol;
    // Table 4: Run 1 start/end, Run 2 start/end, Run 3 end (°C). Documented: τ, q, D at
    // 10/30/75 %, ρ, s0, r_span, r0, ΔT_ss at 0/50/100 %.
    let rows: [(&str, [f64; 5], [f64; 12]); 2] = [
        (
            "link2",
            [23.40, 28.10, 24.40, 28.40, 27.20],
            [
                391.64, 0.10046, 3.686, 5.245, 5.467, 0.14230, 0.096403, 5.0305, 0.4383, 0.438,
                5.441, 5.469,
            ],
        ),
        (
            "link3",
            [23.35, 30.10, 24.34, 30.65, 28.45],
            [
                308.34, 0.05399, 4.944, 7.105, 7.630, 0.24291, 0.124159, 6.0418, 1.6027, 1.603,
                7.537, 7.643,
            ],
        ),
    ];
    for (name, t4, doc) in rows {
        let e = |t: f64| t - 23.38; // the one ambient: the mean of the Run-1 starts, rounded
        let tau = 600.0 / (e(t4[1]) / e(t4[2])).ln();
        let q = (-900.0 / tau).exp();
        let d = |a: f64, b: f64| (e(b) - e(a) * q) / (1.0 - q);
        let (d30, d75, d10) = (d(t4[0], t4[1]), d(t4[2], t4[3]), d(t4[3], t4[4]));
        let rho = (d75 - d30) / (d30 - d10);
        assert!(close(tau, doc[0], 0.005), "{name}: τ {tau}");
        assert!(close(q, doc[1], 5e-6), "{name}: q {q}");
        for (got, want) in [(d10, doc[2]), (d30, doc[3]), (d75, doc[4])] {
            assert!(close(got, want, 5e-4), "{name}: D {got} vs {want}");
        }
        assert!(close(rho, doc[5], 5e-6), "{name}: ρ {rho}");
        // g(s0) = (E(0.30) − E(0.75)) / (E(0.10) − E(0.30)), E(s) = exp(−s/s0)
        let g = |s0: f64| {
            let ex = |s: f64| (-s / s0).exp();
            (ex(0.30) - ex(0.75)) / (ex(0.10) - ex(0.30))
        };
        let s0 = doc[6];
        let dg = (g(s0 + 1e-9) - g(s0 - 1e-9)) / 2e-9;
        assert!(
            (g(s0) - rho).abs() <= dg.abs() * 5e-7,
            "{name}: the printed s0 {s0} does not solve g(s0) = ρ to its digits"
        );
        let ex = |s: f64| (-s / s0).exp();
        let span = (d30 - d10) / (ex(0.10) - ex(0.30));
        let r0 = d10 - span * (1.0 - ex(0.10));
        assert!(close(span, doc[7], 5e-4), "{name}: r_span {span}");
        assert!(close(r0, doc[8], 5e-4), "{name}: r0 {r0}");
        let rise = |s: f64| r0 + span * (1.0 - ex(s));
        for (s, want) in [(0.0, doc[9]), (0.5, doc[10]), (1.0, doc[11])] {
            assert!(close(rise(s), want, 5e-4), "{name}: ΔT_ss({s}) {}", rise(s));
        }
        // The code's calibration agrees with this derivation (to the printed s0's rounding).
        let n = node(name);
        assert!(close(n.tau_min, tau, 1e-9), "{name}");
        let Rise::Saturating {
            r0_k,
            span_k,
            s0: s0_code,
        } = n.rise
        else {
            panic!("{name}: {:?} is not saturating", n.rise);
        };
        assert!(close(s0_code, s0, 5e-7), "{name}: s0 {s0_code}");
        assert!(close(span_k, span, 1e-3), "{name}: span {span_k}");
        assert!(close(r0_k, r0, 1e-3), "{name}: r0 {r0_k}");
    }
    // The assumed base node, as documented (an assumption, not a derivation).
    let base = node("base");
    assert_eq!(base.rise, Rise::Quadratic([0.10, 0.85, 0.50]));
    assert!(close(base.steady_rise_k(0.30), 0.40, 1e-12));
    assert!(close(base.steady_rise_k(1.0), 1.45, 1e-12));
    assert_eq!(base.tau_min, 600.0);
    for n in kr15_paper_nodes() {
        n.validate().unwrap();
    }
}

/// The saturating rises go through the three steady rises D that Table 4 implies, exactly.
#[test]
fn calibration_reproduces_the_three_rises() {
    for link in &TABLE4 {
        let n = node(link.name);
        // D recomputed here from the table (module documentation, steps 1–2).
        let e = |t: f64| t - KR15_PAPER_AMBIENT_C;
        let tau = 600.0 / (e(link.run1.1) / e(link.run2.0)).ln();
        let q = (-900.0 / tau).exp();
        let d = |a: f64, b: f64| (e(b) - e(a) * q) / (1.0 - q);
        assert!((n.tau_min - tau).abs() < 1e-12, "{}", link.name);
        for (s, want) in [
            (0.30, d(link.run1.0, link.run1.1)),
            (0.75, d(link.run2.0, link.run2.1)),
            (0.10, d(link.run2.1, link.run3_end)),
        ] {
            let got = n.steady_rise_k(s);
            assert!(
                (got - want).abs() < 1e-9,
                "{} at {s}: {got} vs {want}",
                n.name
            );
        }
    }
}

/// Losses grow with speed: every default node's rise is strictly increasing on [0, 1].
#[test]
fn every_default_rise_increases_with_speed() {
    let grid: Vec<f64> = (0..=1000).map(|i| i as f64 / 1000.0).collect();
    for n in kr15_paper_nodes() {
        n.rise.check().unwrap();
        let d: Vec<f64> = grid.iter().map(|&s| n.steady_rise_k(s)).collect();
        for (w, s) in d.windows(2).zip(&grid) {
            assert!(w[1] > w[0], "{} at s = {s}: {} → {}", n.name, w[0], w[1]);
        }
        // above the measured 75 % it keeps rising, and never above the plateau
        if let Rise::Saturating { r0_k, span_k, .. } = n.rise {
            assert!(n.steady_rise_k(1.0) > n.steady_rise_k(0.75));
            assert!(n.steady_rise_k(1.0) < r0_k + span_k);
            assert!(n.steady_rise_k(1.0) > n.steady_rise_k(0.30), "{}", n.name);
        }
    }
}

/// The quadratic `[c0, c1, c2]` (`c0 + c1·x + c2·x²`) through three points with distinct x.
fn quadratic_through(p: [(f64, f64); 3]) -> [f64; 3] {
    let [(x0, y0), (x1, y1), (x2, y2)] = p;
    let f01 = (y1 - y0) / (x1 - x0);
    let f12 = (y2 - y1) / (x2 - x1);
    let c2 = (f12 - f01) / (x2 - x0);
    let c1 = f01 - c2 * (x0 + x1);
    let c0 = y0 - c1 * x0 - c2 * x0 * x0;
    [c0, c1, c2]
}

/// What the replaced quadratic calibration did (module documentation): through the same
/// three points it peaked at ~55 % and fell below its 30 % value at 100 %; it fails
/// [`Rise::check`] now.
#[test]
fn replaced_quadratic_as_documented() {
    for (link, coef, vertex, peak, full, r0) in [
        (
            &TABLE4[0],
            [2.5695, 12.2877, -11.2331],
            0.547,
            5.93,
            3.62,
            2.57,
        ),
        (
            &TABLE4[1],
            [3.4192, 16.7351, -14.8273],
            0.564,
            8.14,
            5.33,
            3.42,
        ),
    ] {
        let (_, [d1, d2, d3]) = table4_rises(link, KR15_PAPER_AMBIENT_C);
        let c = quadratic_through([(0.10, d3), (0.30, d1), (0.75, d2)]);
        for (g, w) in c.iter().zip(coef) {
            assert!((g - w).abs() < 5e-5, "{}: {c:?}", link.name);
        }
        let q = Rise::Quadratic(c);
        let v = -c[1] / (2.0 * c[2]);
        assert!((v - vertex).abs() < 5e-4, "{}: vertex {v}", link.name);
        assert!((q.at(v) - peak).abs() < 5e-3, "{}", link.name);
        assert!((q.at(1.0) - full).abs() < 5e-3, "{}", link.name);
        assert!((q.at(0.0) - r0).abs() < 5e-3, "{}", link.name);
        assert!(q.at(1.0) < q.at(0.30), "{}", link.name);
        assert_eq!(q.check().unwrap_err().key, "rise_k");
        // same three points as the saturating calibration
        let sat = node(link.name).rise;
        for s in [0.10, 0.30, 0.75] {
            assert!((q.at(s) - sat.at(s)).abs() < 1e-9);
        }
    }
}

#[test]
fn quadratic_through_recovers_a_quadratic() {
    let f = |x: f64| 1.5 - 2.0 * x + 0.25 * x * x;
    let c = quadratic_through([(0.1, f(0.1)), (0.3, f(0.3)), (0.75, f(0.75))]);
    for (g, w) in c.iter().zip([1.5, -2.0, 0.25]) {
        assert!((g - w).abs() < 1e-12, "{c:?}");
    }
}

#[test]
fn solver_recovers_a_known_s0() {
    let x = [0.10, 0.30, 0.75];
    // g is increasing in s0 and spans (0, 2.25)
    let gs: Vec<f64> = (-30..=40)
        .map(|k| saturating_ratio(x, 10f64.powf(k as f64 / 10.0)))
        .collect();
    assert!(gs.windows(2).all(|w| w[1] > w[0]), "{gs:?}");
    assert!(gs[0] > 0.0 && gs[0] < 1e-80, "{gs:?}");
    assert!((gs[70] - 2.25).abs() < 1e-4, "{gs:?}");
    assert_eq!(saturating_ratio(x, 1e-5), 0.0); // underflows, no NaN
                                                // ρ from the exponentials themselves (no rises to cancel): s0 to full precision, up to
                                                // the conditioning near the straight-line limit.
    for (s0, tol) in [
        (0.002, 1e-13),
        (0.01, 1e-13),
        (0.0964, 1e-13),
        (0.3, 1e-13),
        (1.0, 1e-12),
        (10.0, 1e-10),
        (100.0, 1e-8),
    ] {
        let e = |s: f64| (-s / s0).exp();
        let rho = (e(0.30) - e(0.75)) / (e(0.10) - e(0.30));
        let got = solve_saturating_s0(x, rho).unwrap();
        assert!((got / s0 - 1.0).abs() < tol, "s0 {s0}: {got}");
    }
    // the whole curve through three points of a known one
    for (s0, tol) in [(0.05, 1e-9), (0.0964, 1e-11), (0.3, 1e-11), (1.0, 1e-10)] {
        let (r0, span) = (1.25, 3.5);
        let f = |s: f64| r0 + span * (1.0 - (-s / s0).exp());
        let Rise::Saturating {
            r0_k,
            span_k,
            s0: s,
        } = saturating_through([(0.10, f(0.10)), (0.30, f(0.30)), (0.75, f(0.75))]).unwrap()
        else {
            unreachable!()
        };
        assert!((s / s0 - 1.0).abs() < tol, "s0 {s0}: {s}");
        assert!((r0_k - r0).abs() < 1e3 * tol, "s0 {s0}: r0 {r0_k}");
        assert!((span_k - span).abs() < 1e3 * tol, "s0 {s0}: span {span_k}");
    }
    // other speeds: the limit is (x3 − x2)/(x2 − x1)
    let x = [0.0, 1.0, 3.0];
    let s0 = 0.7;
    let e = |s: f64| (-s / s0).exp();
    let rho = (e(1.0) - e(3.0)) / (e(0.0) - e(1.0));
    assert!((solve_saturating_s0(x, rho).unwrap() - s0).abs() < 1e-13);
    assert!(solve_saturating_s0(x, 1.999).is_ok());
    assert!(solve_saturating_s0(x, 2.0).is_err());
}

#[test]
fn solver_rejects_impossible_ratios() {
    let x = [0.10, 0.30, 0.75];
    for rho in [0.0, -0.5, 2.2500001, 2.5, 100.0, f64::NAN, f64::INFINITY] {
        let e = solve_saturating_s0(x, rho).unwrap_err();
        assert!(e.to_string().contains("outside (0, 2.25)"), "{rho}: {e}");
    }
    // 2.25 itself is the straight line: 0.45/0.2 rounds just above it, so it is caught
    // by the bracket instead
    assert!(solve_saturating_s0(x, 2.25).is_err());
    // within (0, 2.25) in floating point but indistinguishable from the straight line
    let e = solve_saturating_s0(x, 2.25 - 1e-15).unwrap_err();
    assert!(e.to_string().contains("too close"), "{e}");
    for bad in [[0.3, 0.1, 0.75], [0.1, 0.1, 0.75], [0.1, f64::NAN, 0.75]] {
        let e = solve_saturating_s0(bad, 1.0).unwrap_err();
        assert!(e.to_string().contains("strictly increasing"), "{e}");
    }
    // a convex rise (slope growing) or a falling one has no saturating curve
    assert!(saturating_through([(0.1, 1.0), (0.3, 2.0), (0.75, 5.0)]).is_err());
    assert!(saturating_through([(0.1, 3.0), (0.3, 2.0), (0.75, 1.0)]).is_err());
    assert!(saturating_through([(0.1, 1.0), (0.3, 2.0), (0.75, 1.5)]).is_err());
    assert!(saturating_through([(0.1, 1.0), (0.3, 1.0), (0.75, 1.5)]).is_err());
}

#[test]
fn rise_check_names_the_key() {
    let ok = [
        Rise::Quadratic([0.0; 3]),
        Rise::Quadratic([1.0, 0.0, 0.5]),
        Rise::Quadratic([1.0, 2.0, -1.0]), // slope 0 at s = 1
        Rise::Saturating {
            r0_k: -1.0,
            span_k: 0.0,
            s0: 0.1,
        },
        Rise::Saturating {
            r0_k: 0.5,
            span_k: 3.0,
            s0: 5.0,
        },
    ];
    for r in ok {
        r.check().unwrap();
    }
    let bad = [
        (Rise::Quadratic([1.0, -0.1, 0.5]), "rise_k"),
        (Rise::Quadratic([1.0, 2.0, -1.01]), "rise_k"),
        (Rise::Quadratic([f64::NAN, 1.0, 0.0]), "rise_k"),
        (Rise::Quadratic([0.0, 1.0, f64::INFINITY]), "rise_k"),
        (
            Rise::Saturating {
                r0_k: f64::NAN,
                span_k: 1.0,
                s0: 0.1,
            },
            "rise_saturating.r0_k",
        ),
        (
            Rise::Saturating {
                r0_k: 0.0,
                span_k: -1.0,
                s0: 0.1,
            },
            "rise_saturating.span_k",
        ),
        (
            Rise::Saturating {
                r0_k: 0.0,
                span_k: f64::INFINITY,
                s0: 0.1,
            },
            "rise_saturating.span_k",
        ),
        (
            Rise::Saturating {
                r0_k: 0.0,
                span_k: 1.0,
                s0: 0.0,
            },
            "rise_saturating.s0",
        ),
        (
            Rise::Saturating {
                r0_k: 0.0,
                span_k: 1.0,
                s0: f64::NAN,
            },
            "rise_saturating.s0",
        ),
    ];
    for (r, key) in bad {
        let KeyError { key: k, message: m } = r.check().unwrap_err();
        assert_eq!(k, key, "{r:?}: {m}");
        assert!(!m.contains('\n'));
        let e = NodeParams::new("x", 1.0, r).unwrap_err();
        assert!(e.to_string().contains(key), "{e}");
    }
    // the saturating form at its ends
    let r = Rise::Saturating {
        r0_k: 0.5,
        span_k: 3.0,
        s0: 0.2,
    };
    assert_eq!(r.at(0.0), 0.5);
    assert!((r.at(0.2) - (0.5 + 3.0 * (1.0 - (-1.0f64).exp()))).abs() < 1e-15);
    assert!((r.at(1e3) - 3.5).abs() < 1e-15);
}

#[test]
fn warm_up_is_first_order() {
    for n in kr15_paper_nodes() {
        let tau_s = n.tau_min * 60.0;
        let amb = KR15_PAPER_AMBIENT_C;
        let rise = n.steady_rise_k(0.30);
        // 1-minute grid over 10 τ with t = τ inserted; start at ambient.
        let mut t_s: Vec<f64> = (0..=(10.0 * n.tau_min) as usize)
            .map(|k| k as f64 * 60.0)
            .collect();
        let at = t_s.partition_point(|&t| t < tau_s);
        t_s.insert(at, tau_s);
        let m = t_s.len();
        let temp = simulate(&n, &t_s, &vec![Some(0.30); m], &vec![amb; m], amb).unwrap();
        let frac = (temp[at] - amb) / rise;
        assert!((frac - (1.0 - (-1.0f64).exp())).abs() < 1e-12, "{frac}");
        assert!((frac - 0.632).abs() < 5e-4);
        let end = (temp[m - 1] - amb) / rise;
        assert!(end > 0.9999, "{}: {end}", n.name);
        // y0 + A·exp(−t/τ) with y0 = amb + rise, A = −rise, at every sample.
        for (t, y) in t_s.iter().zip(&temp) {
            let fit = amb + rise - rise * (-t / tau_s).exp();
            assert!((y - fit).abs() < 1e-10, "{}: t {t}", n.name);
        }
    }
    // Run 1 of the protocol itself: equally spaced increments shrink by exp(−h/τ).
    let n = node("link3");
    let (t_s, speed, ambient, _) = paper_protocol();
    let temp = simulate(&n, &t_s, &speed, &ambient, 23.35).unwrap();
    let ratio = (-(100.0 / n.tau_min)).exp();
    for k in [0, 200, 500, 700] {
        let d1 = temp[k + 100] - temp[k];
        let d2 = temp[k + 200] - temp[k + 100];
        assert!((d2 / d1 - ratio).abs() < 1e-9);
    }
}

#[test]
fn one_big_step_equals_many_small_steps() {
    for n in kr15_paper_nodes() {
        for speed in [None, Some(0.0), Some(0.3), Some(1.0)] {
            let big = n.step(31.0, 22.0, speed, 7200.0);
            // Rounding of the stored temperature (ulp(30 °C) ≈ 3.6e-15) accumulates with the
            // number of steps, hence the looser bound for 7200 one-second steps.
            for (steps, tol) in [(120, 1e-12), (600, 1e-12), (7200, 1e-10)] {
                let dt = 7200.0 / steps as f64;
                let mut small = 31.0;
                for _ in 0..steps {
                    small = n.step(small, 22.0, speed, dt);
                }
                assert!((big - small).abs() < tol, "{}: {big} vs {small}", n.name);
            }
            // and via simulate on an irregular grid
            let t_s = [0.0, 0.5, 13.0, 600.0, 601.0, 4000.0, 7200.0];
            let out = simulate(&n, &t_s, &[speed; 7], &[22.0; 7], 31.0).unwrap();
            assert!((out[6] - big).abs() < 1e-12);
        }
    }
}

#[test]
fn idle_cools_to_ambient() {
    let n = node("link2");
    let t = n.step(40.0, 21.0, None, 50.0 * n.tau_min * 60.0);
    assert!((t - 21.0).abs() < 1e-12, "{t}");
    // one τ of idle leaves 1/e of the excess
    let t = n.step(31.0, 21.0, None, n.tau_min * 60.0);
    assert!((t - (21.0 + 10.0 / std::f64::consts::E)).abs() < 1e-12);
    // standstill under servo is not idle: it settles at ambient + r0
    let t = n.step(21.0, 21.0, Some(0.0), 1e9);
    let Rise::Saturating { r0_k, .. } = n.rise else {
        panic!("{:?}", n.rise)
    };
    assert!((t - (21.0 + r0_k)).abs() < 1e-12);
    // at steady state nothing changes
    let ss = n.steady_state_c(21.0, Some(0.4));
    assert_eq!(n.step(ss, 21.0, Some(0.4), 3600.0), ss);
}

#[test]
fn simulate_degenerate_and_invalid_inputs() {
    let n = node("link2");
    assert_eq!(
        simulate(&n, &[], &[], &[], 20.0).unwrap(),
        Vec::<f64>::new()
    );
    assert_eq!(
        simulate(&n, &[5.0], &[Some(0.5)], &[20.0], 25.0).unwrap(),
        vec![25.0]
    );
    // non-increasing time stamps pass no time
    let out = simulate(
        &n,
        &[0.0, 600.0, 600.0, 300.0, 900.0],
        &[Some(1.0); 5],
        &[20.0; 5],
        20.0,
    )
    .unwrap();
    assert_eq!(out[2], out[1]);
    assert_eq!(out[3], out[1]);
    assert!((out[4] - n.step(out[1], 20.0, Some(1.0), 600.0)).abs() < 1e-15);
    let e = simulate(&n, &[0.0, 1.0], &[None], &[20.0, 20.0], 20.0).unwrap_err();
    assert!(e.to_string().contains("equal lengths"), "{e}");
    let e = simulate(&n, &[0.0, 1.0], &[None, None], &[20.0], 20.0).unwrap_err();
    assert!(e.to_string().contains("equal lengths"), "{e}");
    for bad in [-0.1, 1.5, f64::NAN] {
        let e = simulate(&n, &[0.0, 1.0], &[Some(bad), None], &[20.0; 2], 20.0).unwrap_err();
        assert!(e.to_string().contains("speed[0]"), "{e}");
    }
    let e = simulate(&n, &[0.0, f64::NAN], &[None; 2], &[20.0; 2], 20.0).unwrap_err();
    assert!(e.to_string().contains("t_s[1]"), "{e}");
    let e = simulate(&n, &[0.0, 1.0], &[None; 2], &[20.0, f64::INFINITY], 20.0).unwrap_err();
    assert!(e.to_string().contains("ambient_c[1]"), "{e}");
    assert!(simulate(&n, &[0.0], &[None], &[20.0], f64::NAN).is_err());
    let mut bad = n.clone();
    bad.tau_min = 0.0;
    assert!(simulate(&bad, &[0.0], &[None], &[20.0], 20.0).is_err());
    let flat = Rise::Quadratic([0.0; 3]);
    for tau in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = NodeParams::new("x", tau, flat).unwrap_err();
        assert!(e.to_string().contains("tau_min"), "{e}");
    }
    assert!(NodeParams::new("x", 1.0, Rise::Quadratic([0.0, f64::NAN, 0.0])).is_err());
    assert!(NodeParams::new(" ", 1.0, flat).is_err());
    assert_eq!(
        NodeParams::new("x", 2.0, Rise::Quadratic([1.0, 2.0, 3.0])).unwrap(),
        NodeParams {
            name: "x".into(),
            tau_min: 2.0,
            rise: Rise::Quadratic([1.0, 2.0, 3.0])
        }
    );
    // dt ≤ 0 in step
    assert_eq!(n.step(30.0, 20.0, Some(1.0), 0.0), 30.0);
    assert_eq!(n.step(30.0, 20.0, Some(1.0), -5.0), 30.0);
}

#[test]
fn lag_of_a_ramp_is_exact() {
    let tau = 300.0;
    let c = 0.01; // K/s
    let t_s = [0.0, 1.0, 7.5, 100.0, 101.0, 900.0, 2000.0, 20000.0];
    let x: Vec<f64> = t_s.iter().map(|t| 5.0 + c * t).collect();
    let y = first_order_lag(&t_s, &x, tau).unwrap();
    for (t, y) in t_s.iter().zip(&y) {
        let want = 5.0 + c * (t - tau * (1.0 - (-t / tau).exp()));
        assert!((y - want).abs() < 1e-12, "t {t}: {y} vs {want}");
    }
    // lags the ramp by c·τ in the end
    assert!((x[7] - y[7] - c * tau).abs() < 1e-9);
}

#[test]
fn lag_of_a_step_is_exact() {
    // x = 0 until t = 50, jumps to 2 (repeated time stamp), then constant.
    let tau = 40.0;
    let t_s = [0.0, 20.0, 50.0, 50.0, 60.0, 90.0, 250.0];
    let x = [0.0, 0.0, 0.0, 2.0, 2.0, 2.0, 2.0];
    let y = first_order_lag(&t_s, &x, tau).unwrap();
    assert_eq!(&y[..4], &[0.0; 4]);
    for k in 4..7 {
        let want = 2.0 * (1.0 - (-(t_s[k] - 50.0) / tau).exp());
        assert!((y[k] - want).abs() < 1e-12, "{k}: {} vs {want}", y[k]);
    }
    // starting off equilibrium with constant x: pure decay (y0 = x0, so use a first jump)
    let y = first_order_lag(&[0.0, 0.0, 1e6], &[1.0, 3.0, 3.0], tau).unwrap();
    assert_eq!(y[1], 1.0);
    assert!((y[2] - 3.0).abs() < 1e-12);
}

#[test]
fn lag_converges_for_dense_samples() {
    // x = sin(ωt), y(0) = 0: y = (sin ωt − ωτ cos ωt + ωτ e^{−t/τ}) / (1 + ω²τ²).
    let (tau, w, t_end) = (120.0, 2.0 * std::f64::consts::PI / 900.0, 3000.0);
    let wt = w * tau;
    let exact =
        |t: f64| ((w * t).sin() - wt * (w * t).cos() + wt * (-t / tau).exp()) / (1.0 + wt * wt);
    let err = |n: usize| {
        let t_s: Vec<f64> = (0..=n).map(|k| t_end * k as f64 / n as f64).collect();
        let x: Vec<f64> = t_s.iter().map(|t| (w * t).sin()).collect();
        let y = first_order_lag(&t_s, &x, tau).unwrap();
        t_s.iter()
            .zip(&y)
            .map(|(t, y)| (y - exact(*t)).abs())
            .fold(0.0, f64::max)
    };
    let errs: Vec<f64> = [25, 50, 100, 200, 400].into_iter().map(err).collect();
    for e in errs.windows(2) {
        let ratio = e[0] / e[1];
        assert!((3.5..4.5).contains(&ratio), "second order: {errs:?}");
    }
    assert!(errs[4] < 5e-4, "{errs:?}");
}

#[test]
fn lag_degenerate_inputs() {
    let t_s = [0.0, 10.0, 20.0];
    let x = [1.0, 5.0, -2.0];
    assert_eq!(first_order_lag(&t_s, &x, 0.0).unwrap(), x.to_vec());
    assert_eq!(first_order_lag(&[], &[], 5.0).unwrap(), Vec::<f64>::new());
    assert_eq!(first_order_lag(&[3.0], &[7.0], 5.0).unwrap(), vec![7.0]);
    assert_eq!(
        first_order_lag(&t_s, &x, f64::INFINITY).unwrap(),
        vec![1.0; 3]
    );
    // non-increasing time: no time passes
    let y = first_order_lag(&[0.0, 10.0, 5.0, 10.0], &[0.0, 1.0, 9.0, 9.0], 10.0).unwrap();
    assert_eq!(y[2], y[1]);
    // tiny and huge steps stay finite and sensible
    let y = first_order_lag(&[0.0, 1e-300, 1e300], &[0.0, 1.0, 1.0], 1.0).unwrap();
    assert!(y[1].abs() < 1e-299 && (y[2] - 1.0).abs() < 1e-15, "{y:?}");
    let y = first_order_lag(&[0.0, 1.0], &[0.0, 1.0], 1e-300).unwrap();
    assert_eq!(y[1], 1.0);
    assert!(first_order_lag(&t_s, &x[..2], 1.0)
        .unwrap_err()
        .to_string()
        .contains("equal lengths"));
    for tau in [-1.0, f64::NAN] {
        assert!(first_order_lag(&t_s, &x, tau)
            .unwrap_err()
            .to_string()
            .contains("tau_s"));
    }
    // NaN propagates rather than being hidden
    let y = first_order_lag(&[0.0, 1.0, 2.0], &[0.0, f64::NAN, 1.0], 1.0).unwrap();
    assert!(y[1].is_nan() && y[2].is_nan());
}
