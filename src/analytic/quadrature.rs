//! Gauss–Legendre quadrature on [−1, 1].

/// Gauss–Legendre nodes and weights on [−1, 1].
#[derive(Clone, Debug)]
pub(super) struct GaussLegendre {
    pub(super) nodes: Vec<f64>,
    pub(super) weights: Vec<f64>,
}

impl GaussLegendre {
    /// The `order`-point rule (exact for polynomials of degree 2·order − 1),
    /// by Newton's iteration on the Legendre polynomial P_order.
    pub(super) fn new(order: usize) -> GaussLegendre {
        let order = order.max(1);
        let mut nodes = Vec::with_capacity(order);
        let mut weights = Vec::with_capacity(order);
        let n = order as f64;
        for k in 0..order {
            // Tricomi's initial guess for the k-th root.
            let mut x = (std::f64::consts::PI * (k as f64 + 0.75) / (n + 0.5)).cos();
            for _ in 0..100 {
                let step = legendre_over_derivative(order, x);
                x -= step;
                if step.abs() <= 1e-16 {
                    break;
                }
            }
            let (p_n, p_n_minus_1) = legendre_pair(order, x);
            let derivative = n * (x * p_n - p_n_minus_1) / (x * x - 1.0);
            nodes.push(x);
            weights.push(2.0 / ((1.0 - x * x) * derivative * derivative));
        }
        GaussLegendre { nodes, weights }
    }
}

/// The Newton step P_n(x) / P_n'(x).
pub(super) fn legendre_over_derivative(n: usize, x: f64) -> f64 {
    let (p_n, p_n_minus_1) = legendre_pair(n, x);
    let derivative = n as f64 * (x * p_n - p_n_minus_1) / (x * x - 1.0);
    p_n / derivative
}

/// (P_n(x), P_{n−1}(x)) by the three-term recurrence.
pub(super) fn legendre_pair(n: usize, x: f64) -> (f64, f64) {
    let (mut p_previous, mut p) = (1.0, x);
    for m in 2..=n {
        let m = m as f64;
        let p_next = ((2.0 * m - 1.0) * x * p - (m - 1.0) * p_previous) / m;
        p_previous = p;
        p = p_next;
    }
    (p, p_previous)
}
