//! The window pass's sums against the row-by-row accumulation they replaced (every row
//! adding its ten terms to ten per-column sums in memory), bit for bit, through the route
//! the CPU takes (AVX2 where it has it) and the portable one.

use super::super::measure::{box_sums, box_sums_body, BoxPass, N_COLS};
use super::*;

/// The accumulation as first written: row after row, each term added to its column's sum.
fn row_by_row(p: &BoxPass) -> Vec<f32> {
    let BoxPass {
        vals,
        gx,
        gy,
        dyv,
        aa,
        nn,
        nxp,
    } = *p;
    let mut cols = vec![0.0f32; N_COLS * nxp];
    for (j, (&gyj, &dy)) in gy.iter().zip(dyv).enumerate() {
        let dy2 = dy * dy;
        for i in 0..nxp {
            let gg = gx[i] * gyj;
            let wgt = gg / (aa * gg + nn);
            let vv = vals[j * nxp + i];
            let (wv, wg, gv) = (wgt * vv, wgt * gg, gg * vv);
            let terms = [
                wv,
                wv * dy,
                wg,
                wg * dy,
                wg * dy2,
                gv,
                gv * dy,
                gv * dy2,
                gv * vv,
                gv * gg,
            ];
            for (k, t) in terms.iter().enumerate() {
                cols[k * nxp + i] += t;
            }
        }
    }
    cols
}

#[test]
fn window_sums_match_the_row_by_row_accumulation_bit_for_bit() {
    let mut rng = StdRng::seed_from_u64(17);
    for trial in 0..500 {
        let nx = rng.random_range(1..70usize);
        let ny = rng.random_range(1..70usize);
        let nxp = nx.div_ceil(LANES) * LANES;
        // Values of any sign and of magnitudes far apart, so that any change in the order of
        // the additions shows in the bits; the padding is zero, as in a pass.
        let mut any = |scale: i32| {
            rng.random_range(-1.0f32..1.0) * 2f32.powi(rng.random_range(-scale..scale))
        };
        let mut gx = vec![0.0f32; nxp];
        let mut vals = vec![0.0f32; ny * nxp];
        for i in 0..nx {
            gx[i] = any(8).abs();
            for j in 0..ny {
                vals[j * nxp + i] = any(12);
            }
        }
        let gy: Vec<f32> = (0..ny).map(|_| any(8).abs()).collect();
        let dyv: Vec<f32> = (0..ny).map(|_| any(6)).collect();
        let (aa, nn) = (any(4).abs(), any(4).abs() + 1e-3);
        let pass = BoxPass {
            vals: &vals,
            gx: &gx,
            gy: &gy,
            dyv: &dyv,
            aa,
            nn,
            nxp,
        };
        let want = row_by_row(&pass);
        let mut got = vec![f32::NAN; N_COLS * nxp];
        box_sums(&pass, &mut got);
        let mut portable = vec![f32::NAN; N_COLS * nxp];
        box_sums_body(&pass, &mut portable);
        for (k, ((w, g), p)) in want.iter().zip(&got).zip(&portable).enumerate() {
            assert_eq!(
                w.to_bits(),
                g.to_bits(),
                "trial {trial}, sum {k}: {w} vs {g}"
            );
            assert_eq!(
                w.to_bits(),
                p.to_bits(),
                "trial {trial}, sum {k} (portable)"
            );
        }
    }
}

/// An 8-bit frame's background sample goes straight into its histogram over all 256 values
/// (`detect::scan`); its statistics must be those `robust_stats` takes of the sample itself,
/// bit for bit: samples of every size to 2,000, narrow and wide, clipped at 0 and 255,
/// constant, two-valued and with outliers.
#[test]
fn the_histogram_of_an_8_bit_sample_gives_the_stats_of_the_sample() {
    use super::super::background::{hist_stats, robust_stats};
    let mut rng = StdRng::seed_from_u64(20_26_11_26);
    assert!(hist_stats(&[0; 256], 0, 255, 0).0.is_nan());
    for case in 0..3000 {
        let n = if case < 50 {
            case + 1
        } else {
            rng.random_range(1..2000)
        };
        let centre: f64 = rng.random_range(-20.0..280.0);
        let sd: f64 = [0.0, 0.3, 1.5, 4.0, 30.0, 200.0][case % 6];
        let noise = Normal::new(0.0, 1.0).unwrap();
        let samples: Vec<u16> = (0..n)
            .map(|i| {
                let v = match case % 5 {
                    // two values
                    3 => centre + if i % 3 == 0 { sd } else { 0.0 },
                    // one sample in ten far away
                    4 if i % 10 == 0 => centre + 120.0,
                    _ => centre + sd * noise.sample(&mut rng),
                };
                v.round().clamp(0.0, 255.0) as u16
            })
            .collect();
        let mut hist = [0u32; 256];
        for &v in &samples {
            hist[v as usize] += 1;
        }
        let (a, b) = (robust_stats(&samples), hist_stats(&hist, 0, 255, n));
        assert_eq!(
            (a.0.to_bits(), a.1.to_bits()),
            (b.0.to_bits(), b.1.to_bits()),
            "case {case}: n {n}, centre {centre:.1}, sd {sd}: {a:?} against {b:?}"
        );
    }
}

/// The background sample's grid is the one the scan took before it had a type: every
/// `every`-th scanned row from the first (`i % every == 0`), and the columns of
/// `(first..w).step_by(step)`.
#[test]
fn the_sample_grid_takes_the_rows_and_columns_it_always_took() {
    use super::super::detect::SampleGrid;
    for w in 1..1200 {
        for n_rows in [1, 2, 31, 32, 33, 63, 64, 65, 146, 500, 1024] {
            let g = SampleGrid::new(w, n_rows);
            let step = (w / SAMPLE_GRID).max(1);
            let every = (n_rows / SAMPLE_GRID).max(1);
            let cols: Vec<usize> = (step / 2..w).step_by(step).collect();
            let got: Vec<usize> = g.cols().collect();
            assert_eq!(got, cols, "w {w}");
            let rows = (0..n_rows).filter(|i| i % every == 0).count();
            assert_eq!(
                (g.every, g.n_rows(n_rows)),
                (every, rows),
                "w {w}, {n_rows} rows"
            );
        }
    }
}
