//! Which of a model's data channels are read-outs and which are injections: what the data,
//! spectra and Bode plots draw for a model of any kind.
//!
//! A read-out is a data channel that is also a residual channel (`r = o − H i` names its
//! residual after the read-out it cleans: the LTP loop's `o1`, `o12`, a state-space model's
//! `outputs`, a user model's `residual` entries that are data channels); every other data
//! channel the model reads is an injection, except the modelled glitches' impulse
//! ([`GLITCH_CHANNEL`]), which is not data. A model whose residuals are none of its data
//! channels (the acceleration domain's `a12 = P o − G g`) has the LTP's read-outs `o1, o12`
//! and guidance injections `i1, i12`, as the experiments it is fitted to record them. A
//! channel with an LTP name (`o1`, `i12`, `g1` …) that the model gives no unit has the LTP's.

use super::glitch::GLITCH_CHANNEL;
use super::ltp::ltp_channel_unit;
use super::traits::Model;

/// A named channel and its SI unit (`""`: unknown).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Channel {
    pub name: String,
    pub unit: String,
}

/// A model's read-outs and injections, in the order of its data channels (module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelRoles {
    pub readouts: Vec<Channel>,
    pub injections: Vec<Channel>,
}

impl ChannelRoles {
    /// The roles of `model`'s channels, with the units it declares.
    ///
    /// ```
    /// use occam::model::{ChannelRoles, LtpModel, LtpModelOptions};
    /// let roles = ChannelRoles::of(&LtpModel::new("loop", LtpModelOptions::default()));
    /// let names = |c: &[occam::model::Channel]| c.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
    /// assert_eq!(names(&roles.readouts), ["o1", "o12"]);
    /// assert_eq!(names(&roles.injections), ["i1", "i12"]);
    /// assert_eq!(roles.readouts[0].unit, "m");
    /// ```
    pub fn of(model: &dyn Model) -> Self {
        let data = model.data_channels();
        let units = model.channel_units();
        let res = model.residual_channels();
        // a channel named as the LTP's (a user model of the loop) has its unit unless declared
        let unit = |k: usize| match units.get(k).filter(|u| !u.is_empty()) {
            Some(u) => u.clone(),
            None => ltp_channel_unit(&data[k]).to_string(),
        };
        let readout = |c: &String| res.contains(c);
        if !data.iter().any(readout) {
            let ltp = |names: [&str; 2]| {
                names
                    .iter()
                    .map(|n| Channel {
                        name: n.to_string(),
                        unit: ltp_channel_unit(n).to_string(),
                    })
                    .collect()
            };
            return ChannelRoles {
                readouts: ltp(["o1", "o12"]),
                injections: ltp(["i1", "i12"]),
            };
        }
        let pick = |keep: &dyn Fn(&String) -> bool| {
            data.iter()
                .enumerate()
                .filter(|(_, c)| keep(c))
                .map(|(k, c)| Channel {
                    name: c.clone(),
                    unit: unit(k),
                })
                .collect()
        };
        ChannelRoles {
            readouts: pick(&|c| readout(c)),
            injections: pick(&|c| !readout(c) && c != GLITCH_CHANNEL),
        }
    }

    /// The unit every read-out shares, if they share one that is known.
    pub fn readout_unit(&self) -> Option<&str> {
        let first = self.readouts.first()?.unit.as_str();
        (!first.is_empty() && self.readouts.iter().all(|c| c.unit == first)).then_some(first)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::state_space::{StateSpaceDef, StateSpaceModel};
    use crate::model::{AccelModel, GlitchModel};
    use std::sync::Arc;

    fn names(c: &[Channel]) -> Vec<&str> {
        c.iter().map(|c| c.name.as_str()).collect()
    }

    #[test]
    fn a_state_space_model_reads_out_its_outputs_and_injects_its_inputs() {
        let def: StateSpaceDef = toml::from_str(
            r#"
            name = "two"
            parameters = ["k"]
            unit = { k = "s⁻²", pos_a = "m", force = "m s⁻²" }
            inputs = ["force"]
            outputs = ["pos_a", "pos_b"]
            a = [[0, 0, 1, 0], [0, 0, 0, 1], ["-k", 0, -0.1, 0], [0, "-k", 0, -0.1]]
            b = [[0], [0], [1], [0]]
            c = [[1, 0, 0, 0], [0, 1, 0, 0]]
        "#,
        )
        .unwrap();
        let m = StateSpaceModel::new(&def).unwrap();
        assert_eq!(m.param_units(), ["s⁻²"]);
        let roles = ChannelRoles::of(&m);
        assert_eq!(names(&roles.readouts), ["pos_a", "pos_b"]);
        assert_eq!(names(&roles.injections), ["force"]);
        assert_eq!(roles.readouts[0].unit, "m");
        assert_eq!(roles.readouts[1].unit, "", "pos_b was given no unit");
        assert_eq!(roles.injections[0].unit, "m s⁻²");
        // pos_b has no unit: the read-outs share none
        assert_eq!(roles.readout_unit(), None);
    }

    #[test]
    fn a_unit_for_a_name_the_model_lacks_is_refused_by_name() {
        let def: StateSpaceDef = toml::from_str(
            r#"
            name = "one"
            parameters = ["k"]
            unit = { pos = "m" }
            inputs = ["u"]
            outputs = ["y"]
            a = [[0, 1], ["-k", -0.1]]
            b = [[0], [1]]
            c = [[1, 0]]
        "#,
        )
        .unwrap();
        let err = StateSpaceModel::new(&def).unwrap_err();
        assert!(err.contains("unit.pos"), "{err}");
        assert!(err.contains("data channels = [y, u]"), "{err}");
    }

    #[test]
    fn the_acceleration_domain_and_glitches_keep_the_ltp_channels() {
        let accel = ChannelRoles::of(&AccelModel::new("a", Default::default()));
        assert_eq!(names(&accel.readouts), ["o1", "o12"]);
        assert_eq!(names(&accel.injections), ["i1", "i12"]);
        let ltp = crate::model::LtpModel::new("loop", Default::default());
        let g = GlitchModel::new(
            "g",
            Arc::new(ltp),
            vec!["a".into()],
            vec![("a".into(), 3000.0)],
            2.0,
        )
        .unwrap();
        let roles = ChannelRoles::of(&g);
        assert_eq!(
            names(&roles.injections),
            ["i1", "i12"],
            "the impulse is no data"
        );
        assert_eq!(roles.readout_unit(), Some("m"));
    }
}
