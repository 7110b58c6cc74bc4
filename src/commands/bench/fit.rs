//! Least-squares fits for the studies.

/// Fits `y = c x^p` through positive points by least squares on
/// `ln y = ln c + p ln x`; returns `(p, c)`, or `None` with fewer than two
/// distinct `x`.
pub fn power_law(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    if logs.len() < 2 {
        return None;
    }
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let p = sxy / sxx;
    Some((p, (my - p * mx).exp()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_power_law() {
        let pts: Vec<(f64, f64)> = [900.0, 3600.0, 10_000.0]
            .iter()
            .map(|&x: &f64| (x, 3e-6 * x.powf(1.4)))
            .collect();
        let (p, c) = power_law(&pts).expect("fits");
        assert!((p - 1.4).abs() < 1e-12);
        assert!((c / 3e-6 - 1.0).abs() < 1e-9);
        assert_eq!(power_law(&pts[..1]), None);
        assert_eq!(power_law(&[(2.0, 1.0), (2.0, 3.0)]), None);
    }
}
