//! Checks of a model as a whole: its shape ([`validate_shape`]), finite coefficients
//! ([`check_finite`]), that every parameter moves some coefficient ([`check_identifiable`]), and its coefficients at one frequency.

use super::bin::{Bin, MAX_CHANNELS, MAX_CONSTS, MAX_RESIDUALS};
use super::traits::Model;
use num_complex::{Complex, Complex64};
use num_dual::Dual64;

/// Checks that a model's shape is usable by the likelihood: names unique and non-empty, 1 to
/// [`MAX_RESIDUALS`] residual channels, at most [`MAX_CHANNELS`] data channels and [`MAX_CONSTS`] constants.
pub fn validate_shape(m: &dyn Model) -> Result<(), String> {
    let name = m.name();
    let nr = m.residual_channels().len();
    if nr == 0 || nr > MAX_RESIDUALS {
        return Err(format!(
            "model `{name}` has {nr} residual channels; 1 to {MAX_RESIDUALS} are supported"
        ));
    }
    let nc = m.data_channels().len();
    if nc == 0 || nc > MAX_CHANNELS {
        return Err(format!(
            "model `{name}` reads {nc} data channels; 1 to {MAX_CHANNELS} are supported"
        ));
    }
    if m.n_consts() > MAX_CONSTS {
        return Err(format!(
            "model `{name}` needs {} constants per bin; at most {MAX_CONSTS} are supported",
            m.n_consts()
        ));
    }
    for (what, list) in [
        ("parameter", m.param_names()),
        ("data channel", m.data_channels()),
        ("residual channel", m.residual_channels()),
    ] {
        for (i, a) in list.iter().enumerate() {
            if a.is_empty() {
                return Err(format!("model `{name}`: a {what} has an empty name"));
            }
            if list[..i].contains(a) {
                return Err(format!("model `{name}`: {what} `{a}` is listed twice"));
            }
        }
    }
    Ok(())
}

/// Errors if some coefficient is not finite at `theta` over `freqs`, naming the model, the
/// coefficient (`coefficients.<residual>.<data>`), the frequency and, where the model can say,
/// the part it comes from and why ([`Model::explain_non_finite`]). Run before
/// [`check_identifiable`]: a NaN coefficient would otherwise surface as "no effect" or as a
/// singular noise matrix, far from its cause.
pub fn check_finite(m: &dyn Model, theta: &[f64], freqs: &[f64], fs: f64) -> Result<(), String> {
    let nc = m.data_channels().len();
    for &f in freqs {
        let c = coefficients_at(m, theta, f, fs);
        if let Some(k) = c
            .iter()
            .position(|z| !(z.re.is_finite() && z.im.is_finite()))
        {
            let entry = format!(
                "coefficients.{}.{}",
                m.residual_channels()[k / nc],
                m.data_channels()[k % nc]
            );
            let what = m
                .explain_non_finite(theta, f, fs)
                .unwrap_or_else(|| format!("{entry} is {}", c[k]));
            return Err(format!("model `{}`: at f = {f:.4e} Hz, {what}", m.name()));
        }
    }
    Ok(())
}

/// Errors if some parameter has no effect on any coefficient at `theta` over `freqs` (the
/// dual derivative of every coefficient with respect to it is zero at every frequency).
pub fn check_identifiable(
    m: &dyn Model,
    theta: &[f64],
    freqs: &[f64],
    fs: f64,
) -> Result<(), String> {
    let np = m.param_names().len();
    if theta.len() != np {
        return Err(format!(
            "model `{}`: θ has {} values for {np} parameters",
            m.name(),
            theta.len()
        ));
    }
    let ncoef = m.data_channels().len() * m.residual_channels().len();
    let mut consts = vec![Complex64::new(0.0, 0.0); m.n_consts()];
    let mut out = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); ncoef];
    let mut seen = vec![false; np];
    let mut th: Vec<Dual64> = theta.iter().map(|&x| Dual64::from(x)).collect();
    for &f in freqs {
        m.bin_consts(f, fs, &mut consts);
        let bin = Bin {
            f,
            fs,
            consts: &consts,
        };
        for a in 0..np {
            if seen[a] {
                continue;
            }
            th[a] = Dual64::from(theta[a]).derivative();
            m.coefficients_dual(&th, &bin, &mut out);
            th[a] = Dual64::from(theta[a]);
            seen[a] = out.iter().any(|z| {
                (z.re.eps != 0.0 && z.re.eps.is_finite())
                    || (z.im.eps != 0.0 && z.im.eps.is_finite())
            });
        }
    }
    let dead: Vec<String> = m
        .param_names()
        .iter()
        .zip(&seen)
        .filter(|(_, s)| !**s)
        .map(|(p, _)| format!("`{p}`"))
        .collect();
    if dead.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "model `{}`: parameter{} {} ha{} no effect on any coefficient at this θ \
             over the {} frequencies checked, so the data cannot determine {}",
            m.name(),
            if dead.len() == 1 { "" } else { "s" },
            dead.join(", "),
            if dead.len() == 1 { "s" } else { "ve" },
            freqs.len(),
            if dead.len() == 1 { "it" } else { "them" },
        ))
    }
}

/// The `f64` coefficients of `m` at θ and frequency `f` (constants computed on the spot): a
/// convenience for tests, plots and the simulator, not for hot paths.
pub fn coefficients_at(m: &dyn Model, theta: &[f64], f: f64, fs: f64) -> Vec<Complex64> {
    let mut consts = vec![Complex64::new(0.0, 0.0); m.n_consts()];
    m.bin_consts(f, fs, &mut consts);
    let mut out =
        vec![Complex64::new(0.0, 0.0); m.data_channels().len() * m.residual_channels().len()];
    m.coefficients(
        theta,
        &Bin {
            f,
            fs,
            consts: &consts,
        },
        &mut out,
    );
    out
}
