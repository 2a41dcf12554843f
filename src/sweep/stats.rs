//! The sweep's summary: probability of deployment with its 95 % Wilson
//! interval, quantiles of deploy time and of the largest latch load, which
//! sleeve latches last how often, and the rank correlation (Spearman) of
//! each parameter with deploy time and with the largest latch load.

use super::row::{ran_as_asked, Row};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The 0.975 quantile of the standard normal: a two-sided 95 % interval.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Wilson score interval of a proportion `k` of `n` at normal quantile `z`.
pub fn wilson(k: u64, n: u64, z: f64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let n = n as f64;
    let p = k as f64 / n;
    let z2 = z * z;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// The q-quantile of `sorted` (ascending, not empty), interpolated linearly
/// between order statistics (Hyndman & Fan type 7, numpy's default).
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Ranks 1..n, ties given their mean rank.
pub fn ranks(v: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && v[order[j + 1]] == v[order[i]] {
            j += 1;
        }
        let mean = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            r[k] = mean;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation (Pearson's of the ranks); None for fewer
/// than 3 pairs or a constant variable.
pub fn spearman(x: &[f64], y: &[f64]) -> Option<f64> {
    if x.len() != y.len() || x.len() < 3 {
        return None;
    }
    let (rx, ry) = (ranks(x), ranks(y));
    let n = x.len() as f64;
    let (mx, my) = (rx.iter().sum::<f64>() / n, ry.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in rx.iter().zip(&ry) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

/// Quantiles of a sample.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Quantiles {
    pub count: usize,
    pub min: f64,
    pub q05: f64,
    pub q25: f64,
    pub median: f64,
    pub q75: f64,
    pub q95: f64,
    pub max: f64,
}

impl Quantiles {
    pub fn of(values: &[f64]) -> Option<Quantiles> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(Quantiles {
            count: v.len(),
            min: v[0],
            q05: quantile(&v, 0.05),
            q25: quantile(&v, 0.25),
            median: quantile(&v, 0.5),
            q75: quantile(&v, 0.75),
            q95: quantile(&v, 0.95),
            max: v[v.len() - 1],
        })
    }
}

/// A parameter's rank correlations.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Correlation {
    pub key: String,
    pub column: String,
    /// With deploy time (deployed samples).
    pub spearman_deploy_time: Option<f64>,
    /// With the largest latch load (samples with a latch).
    pub spearman_latch_load: Option<f64>,
}

/// `summary.json`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Summary {
    pub sweep: String,
    pub sweep_id: String,
    pub samples: u64,
    /// Rows by stop reason.
    pub stop_reasons: BTreeMap<String, u64>,
    /// Rows whose stop reason is error, invalid or panic.
    pub failed: u64,
    pub deployed: u64,
    /// Rows that ran and needed a fallback that accepts a result known to
    /// be inexact (`accepting_fallbacks` > 0): what of the study rests on
    /// rescue rather than on the model.
    pub rescued: u64,
    pub p_deploy: f64,
    /// 95 % Wilson interval of `p_deploy`.
    pub p_deploy_low: f64,
    pub p_deploy_high: f64,
    /// Deploy time (s) of the deployed samples.
    pub deploy_time_s: Option<Quantiles>,
    /// The largest latch load of each sample: peak force (N) when its
    /// latches are compliant, else impulse (N s); `latch_load_unit` says which.
    pub latch_load: Option<Quantiles>,
    pub latch_load_unit: String,
    /// The deployed truss's first natural frequency (Hz) over the samples
    /// that have one.
    #[serde(default)]
    pub first_frequency_hz: Option<Quantiles>,
    /// How often each sleeve latched last (deployed samples), most often first.
    pub last_latch: Vec<(String, u64)>,
    pub correlations: Vec<Correlation>,
    /// The parameter with the largest |Spearman| with deploy time.
    pub drives_deploy_time: Option<String>,
    /// The parameter with the largest |Spearman| with the latch load.
    pub drives_latch_load: Option<String>,
}

fn strongest(c: &[Correlation], f: fn(&Correlation) -> Option<f64>) -> Option<String> {
    c.iter()
        .filter_map(|x| f(x).map(|r| (r.abs(), x)))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, x)| x.key.clone())
}

/// The summary of `rows` (one per sample, in index order); `keys` and
/// `columns` name the parameters.
pub fn summarize(
    name: &str,
    sweep_id: &str,
    keys: &[String],
    columns: &[String],
    rows: &[Row],
) -> Summary {
    let n = rows.len() as u64;
    let mut stop_reasons = BTreeMap::new();
    for r in rows {
        *stop_reasons.entry(r.stop_reason.clone()).or_insert(0) += 1;
    }
    let failed = rows
        .iter()
        .filter(|r| !ran_as_asked(&r.stop_reason))
        .count() as u64;
    let dep: Vec<&Row> = rows
        .iter()
        .filter(|r| r.deployed && r.deploy_time_s.is_some())
        .collect();
    let k = dep.len() as u64;
    let rescued = rows
        .iter()
        .filter(|r| r.accepting_fallbacks.is_some_and(|n| n > 0))
        .count() as u64;
    let (lo, hi) = wilson(k, n, Z95);
    let times: Vec<f64> = dep.iter().filter_map(|r| r.deploy_time_s).collect();
    let loaded: Vec<&Row> = rows
        .iter()
        .filter(|r| r.largest_latch_load().is_some())
        .collect();
    let loads: Vec<f64> = loaded
        .iter()
        .filter_map(|r| r.largest_latch_load())
        .collect();
    let compliant = rows.iter().any(|r| r.max_latch_peak_force_n.is_some());
    let mut last: BTreeMap<String, u64> = BTreeMap::new();
    for r in &dep {
        if let Some(l) = &r.last_latch {
            *last.entry(l.clone()).or_insert(0) += 1;
        }
    }
    let mut last_latch: Vec<(String, u64)> = last.into_iter().collect();
    last_latch.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let correlations: Vec<Correlation> = keys
        .iter()
        .zip(columns)
        .enumerate()
        .map(|(i, (key, column))| {
            let px: Vec<f64> = dep.iter().map(|r| r.params[i]).collect();
            let lx: Vec<f64> = loaded.iter().map(|r| r.params[i]).collect();
            Correlation {
                key: key.clone(),
                column: column.clone(),
                spearman_deploy_time: spearman(&px, &times),
                spearman_latch_load: spearman(&lx, &loads),
            }
        })
        .collect();
    Summary {
        sweep: name.to_string(),
        sweep_id: sweep_id.to_string(),
        samples: n,
        stop_reasons,
        failed,
        deployed: k,
        rescued,
        p_deploy: if n > 0 { k as f64 / n as f64 } else { 0.0 },
        p_deploy_low: lo,
        p_deploy_high: hi,
        deploy_time_s: Quantiles::of(&times),
        latch_load: Quantiles::of(&loads),
        latch_load_unit: if compliant { "N" } else { "N s" }.into(),
        first_frequency_hz: Quantiles::of(
            &rows
                .iter()
                .filter_map(|r| r.first_frequency_hz)
                .collect::<Vec<_>>(),
        ),
        last_latch,
        drives_deploy_time: strongest(&correlations, |c| c.spearman_deploy_time),
        drives_latch_load: strongest(&correlations, |c| c.spearman_latch_load),
        correlations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rescued_counts_the_rows_that_accepted_an_inexact_result() {
        let row = |i: u64, reason: &str, accepting: Option<u64>| {
            let mut r = Row::failed(i, i, vec![1.0], reason, String::new());
            r.accepting_fallbacks = accepting;
            r
        };
        let rows = [
            row(0, "deployed", Some(0)),
            row(1, "deployed", Some(3)),
            row(2, "error", Some(1)),
            row(3, "invalid", None),
        ];
        let s = summarize("t", "id", &["k".into()], &["p_k".into()], &rows);
        assert_eq!(s.rescued, 2);
        assert_eq!(s.samples, 4);
    }

    #[test]
    fn wilson_closed_form() {
        // k = 8 of n = 10 at z = 2 (by hand): p = 0.8, z^2/n = 0.4,
        // centre = (0.8 + 0.2) / 1.4 = 5/7,
        // half = (2 / 1.4) sqrt(0.016 + 0.01) = (10/7) sqrt(0.026).
        let (lo, hi) = wilson(8, 10, 2.0);
        let half = 10.0 / 7.0 * 0.026f64.sqrt();
        assert!((lo - (5.0 / 7.0 - half)).abs() < 1e-15, "{lo}");
        assert!((hi - (5.0 / 7.0 + half)).abs() < 1e-15, "{hi}");
        // all successes: the upper end is 1, the lower n / (n + z^2)
        let (lo, hi) = wilson(10, 10, 2.0);
        assert!((lo - 10.0 / 14.0).abs() < 1e-15 && hi == 1.0, "{lo} {hi}");
    }

    #[test]
    fn quantiles_of_a_known_list() {
        // 1..=5: type 7 gives q25 = 2, median 3, q05 = 1 + 0.2, q95 = 4.8
        let q = Quantiles::of(&[5.0, 3.0, 1.0, 4.0, 2.0]).unwrap();
        assert_eq!(
            (q.min, q.q25, q.median, q.q75, q.max),
            (1.0, 2.0, 3.0, 4.0, 5.0)
        );
        assert!((q.q05 - 1.2).abs() < 1e-15 && (q.q95 - 4.8).abs() < 1e-15);
        // even count: median between the middle two
        assert_eq!(quantile(&[1.0, 2.0, 10.0, 20.0], 0.5), 6.0);
    }

    #[test]
    fn spearman_monotone_antitone_ties() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        let up = [0.1, 5.0, 7.0, 100.0, 1e6]; // monotone, not linear
        let down = [9.0, 3.0, 2.0, 1.5, -4.0];
        assert_eq!(spearman(&x, &up), Some(1.0));
        assert_eq!(spearman(&x, &down), Some(-1.0));
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
        // x against a swap of the middle pair: 1 - 6 * 2 / (5 * 24) = 0.9
        let r = spearman(&x, &[1.0, 3.0, 2.0, 4.0, 5.0]).unwrap();
        assert!((r - 0.9).abs() < 1e-15, "{r}");
        assert_eq!(spearman(&x, &[1.0; 5]), None);
    }
}
