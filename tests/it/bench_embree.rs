//! `raylab bench --embree` (only with the `embree` feature): a raylab/Embree ratio line for
//! every case (instancing too), ray kind and thread count, Embree's packets of 16 on the same
//! rays, build lines, and hit agreement of at least 99.9%.
//!
//! 4,900 rays, not 5,000: coherent rays fill a square image of ceil(sqrt(n)) pixels a side,
//! and at 71 (odd) the middle column of camera rays lies in the plane y = 0 of the report
//! room's floor: those rays graze the floor and meet the far wall exactly on its bottom edge,
//! which Embree counts as a hit and raylab's Möller–Trumbore test, by rounding, as a miss (9
//! rays, 99.82% agreement). In the Cornell box, camera rays on the image diagonals run exactly
//! into the corner edge where the ceiling (y = 1) meets the x = 1 wall, at any image size (4 of
//! 4,900 rays here, 99.92%). Both are deterministic, and both are rays that touch a surface's
//! boundary only; rays on an edge shared by two triangles of one surface hit one of them
//! (`build::primitives` tests it).

use std::process::Command;

/// The six figures of the line `embree CASE KIND THREADS raylab Embree ratio raylab Embree
/// ratio` (closest hit, then occlusion).
fn ratio_row(text: &str, case: &str, kind: &str, threads: &str) -> Vec<f64> {
    text.lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .find(|w| w.len() == 10 && w[..4] == ["embree", case, kind, threads])
        .unwrap_or_else(|| panic!("no ratio line for {case} {kind} {threads}\n{text}"))[4..]
        .iter()
        .map(|v| v.parse().unwrap())
        .collect()
}

#[test]
fn bench_embree_reports_ratios_and_agrees_with_embree() {
    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([
            "bench",
            "--embree",
            "--rays",
            "4900",
            "--subdivisions",
            "3",
            "--threads",
            "1,2",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("embree comparison: Embree 3."), "{text}");
    for case in ["report-room", "cornell-box", "icosphere-1m", "instances"] {
        for kind in ["coherent", "incoherent"] {
            for threads in ["1", "2"] {
                let row = ratio_row(&text, case, kind, threads);
                assert!(row.iter().all(|v| v.is_finite() && *v > 0.0), "{row:?}");
                let ratio = |i: usize| row[i] / row[i + 1];
                // Printed to two decimals: the ratio columns match the M/s columns.
                assert!((ratio(0) - row[2]).abs() <= 0.01 + 0.05 * row[2], "{row:?}");
                assert!((ratio(3) - row[5]).abs() <= 0.01 + 0.05 * row[5], "{row:?}");
                // Embree's packets of 16 on the same rays: the same hits as its single rays
                // (the bench fails otherwise), and positive rates.
                let packets = text
                    .lines()
                    .find(|l| {
                        l.split_whitespace().take(5).collect::<Vec<_>>()
                            == ["embree", case, kind, threads, "threads,"]
                            && l.contains("Embree packets of 16")
                    })
                    .unwrap_or_else(|| {
                        panic!("no packet line for {case} {kind} {threads}\n{text}")
                    });
                assert!(packets.ends_with("same hits"), "{packets}");
                let rates: Vec<f64> = packets
                    .split(" M/s")
                    .filter_map(|part| part.rsplit(' ').next()?.parse().ok())
                    .collect();
                assert!(
                    rates.len() == 2 && rates.iter().all(|&r| r > 0.0),
                    "{packets}"
                );
            }
            let agreement: f64 = text
                .lines()
                .find(|l| {
                    l.starts_with(&format!("embree {case}"))
                        && l.contains(&format!("agreement {kind}:"))
                })
                .and_then(|l| l.split_whitespace().find(|w| w.ends_with('%')))
                .unwrap_or_else(|| panic!("no agreement line for {case} {kind}\n{text}"))
                .trim_end_matches('%')
                .parse()
                .unwrap();
            assert!(agreement >= 99.9, "{case} {kind}: {agreement}%\n{text}");
        }
        for threads in ["1", "2"] {
            assert!(
                text.lines()
                    .any(|l| l.starts_with(&format!("embree {case}"))
                        && l.contains(&format!("build, {threads} threads: raylab"))
                        && l.contains("Embree commit")),
                "no build line for {case} at {threads} threads\n{text}"
            );
        }
    }
}

#[test]
fn bench_embree_rounds_print_medians_and_the_range_of_ratios() {
    let o = Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args([
            "bench",
            "--embree",
            "--case",
            "cornell-box",
            "--rays",
            "900",
            "--threads",
            "1",
            "--rounds",
            "3",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        text.contains("median rates and ratios of 3 rounds"),
        "{text}"
    );
    for kind in ["coherent", "incoherent"] {
        // "... KIND 1 threads, ratios over 3 rounds: closest LO-HI, occlusion LO-HI"; the
        // median ratios lie within the rounds' range (both printed to two decimals).
        let range_line = text
            .lines()
            .find(|l| l.contains(&format!("{kind} 1 threads, ratios over 3 rounds: closest")))
            .unwrap_or_else(|| panic!("no range line for {kind}\n{text}"));
        let ranges: Vec<(f64, f64)> = range_line
            .split_whitespace()
            .filter(|w| w.contains('-') && w.starts_with(|c: char| c.is_ascii_digit()))
            .map(|w| {
                let (lo, hi) = w.trim_end_matches(',').split_once('-').unwrap();
                (lo.parse().unwrap(), hi.parse().unwrap())
            })
            .collect();
        assert_eq!(ranges.len(), 2, "{range_line}");
        let row = ratio_row(&text, "cornell-box", kind, "1");
        for (ratio, (lo, hi)) in [row[2], row[5]].into_iter().zip(ranges) {
            assert!(lo <= hi && lo > 0.0, "{range_line}");
            assert!(
                ratio >= lo - 0.005 && ratio <= hi + 0.005,
                "{ratio} {range_line}"
            );
        }
    }
}
