//! `filter --diagnostics`: the innovation diagnostics file — the statistics are
//! `kalman::diagnostics`'; this module only collects the steps and lays out the JSON.

use std::path::Path;

use kalman::diagnostics::{InnovationSummary, Innovations};

use crate::error::{Error, Result};

/// Confidence of every band in the file.
pub const CONFIDENCE: f64 = 0.95;

/// The collector for a filter with `m` channels.
///
/// # Errors
/// [`Error::Kalman`] (context "diagnostics") if the library refuses (m = 0 cannot come
/// from a parsed model).
pub fn collector(m: usize) -> Result<Innovations> {
    Innovations::new(m, CONFIDENCE).map_err(diagnostics_error)
}

/// The library's refusal of a diagnostics computation.
pub(crate) fn diagnostics_error(source: kalman::Error) -> Error {
    Error::Kalman {
        context: "diagnostics",
        source,
    }
}

/// The diagnostics JSON of a collected pass with `lags` lags.
///
/// # Errors
/// [`Error::Invalid`] naming the data file if a channel has no more observed innovations
/// than `lags` (the record is too short for the test).
pub fn json(acc: &Innovations, lags: usize, data: &Path) -> Result<String> {
    let s = acc.summary(lags).map_err(|e| match e {
        kalman::Error::Dimension { value, .. } => Error::invalid(
            data,
            format!(
                "--diagnostics-lags {lags}: a measurement channel has {value} observed \
                 innovations; the autocorrelation and Ljung–Box test need more than {lags} \
                 (use fewer lags or a longer record)"
            ),
        ),
        e => diagnostics_error(e),
    })?;
    Ok(layout(&s))
}

/// The file's layout (numbers in full precision; non-finite values are `null`).
fn layout(s: &InnovationSummary) -> String {
    use serde_json::json;
    let channels: Vec<serde_json::Value> = s
        .channels
        .iter()
        .enumerate()
        .map(|(i, c)| {
            json!({
                "channel": format!("z{}", i + 1),
                "observed": c.observed,
                "acf": c.acf,
                "acf_bound": c.acf_bound,
                "ljung_box": {
                    "lags": c.ljung_box.lags,
                    "statistic": c.ljung_box.statistic,
                    "dof": c.ljung_box.dof,
                    "p_value": c.ljung_box.p_value,
                },
            })
        })
        .collect();
    let v = json!({
        "steps": s.steps,
        "measured_steps": s.measured_steps,
        "log_likelihood": s.log_likelihood,
        "confidence": s.confidence,
        "nis": {
            "mean": s.nis_mean,
            "dof": s.nis_dof,
            "band": [s.nis_band.0, s.nis_band.1],
            "mean_in_band": s.nis_mean_in_band(),
            "outside_step_band_fraction": s.nis_outside_fraction,
            "expected_outside_fraction": 1.0 - s.confidence,
        },
        "innovations": channels,
    });
    let mut text = serde_json::to_string_pretty(&v).unwrap_or_else(|_| v.to_string());
    text.push('\n');
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_collector_is_a_typed_kalman_error() {
        // m = 0 channels: the library refuses; the error names the stage and keeps the
        // library's variant for a caller to match.
        match collector(0) {
            Err(Error::Kalman {
                context: "diagnostics",
                source: kalman::Error::Dimension { .. },
            }) => {}
            other => panic!("expected Error::Kalman for diagnostics, got {other:?}"),
        }
    }
}
