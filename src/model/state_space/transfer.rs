//! `kind = "transfer_matrix"`: `y = H(s) u` entry by entry, as a user-defined model with
//! coefficients `o → o = 1`, `o → i = −(H_oi)`.

use super::def::TransferMatrixDef;
use crate::model::user::UserModelDef;
use std::collections::BTreeMap;

/// The user-defined model of a transfer matrix (data channels: outputs, then inputs; residual
/// channels: the outputs). Names of `h` that are not declared outputs or inputs are errors
/// naming `h.<output>.<input>`; everything else is checked by
/// [`UserModel::new`](crate::model::user::UserModel::new) (see [`user_error`] for its messages).
pub fn to_user_def(def: &TransferMatrixDef) -> Result<UserModelDef, String> {
    let fail = |entry: String, msg: String| {
        format!("transfer-matrix model `{}`: {entry}: {msg}", def.name)
    };
    if let Some(x) = def.inputs.iter().find(|x| def.outputs.contains(x)) {
        return Err(fail(
            "inputs".into(),
            format!("`{x}` is both an input and an output; a data channel is one or the other"),
        ));
    }
    let mut coefficients: BTreeMap<String, BTreeMap<String, String>> = def
        .outputs
        .iter()
        .map(|o| (o.clone(), BTreeMap::from([(o.clone(), "1".to_string())])))
        .collect();
    for (o, row) in &def.h {
        let Some(out) = coefficients.get_mut(o) else {
            return Err(fail(
                format!("h.{o}"),
                format!(
                    "`{o}` is not a declared output; outputs = [{}]",
                    def.outputs.join(", ")
                ),
            ));
        };
        for (i, text) in row {
            if !def.inputs.contains(i) {
                return Err(fail(
                    format!("h.{o}.{i}"),
                    format!(
                        "`{i}` is not a declared input; inputs = [{}]",
                        def.inputs.join(", ")
                    ),
                ));
            }
            out.insert(i.clone(), format!("-({text})"));
        }
    }
    Ok(UserModelDef {
        name: def.name.clone(),
        parameters: def.parameters.clone(),
        unit: def.unit.clone(),
        physical_limits: def.physical_limits.clone(),
        data: def.outputs.iter().chain(&def.inputs).cloned().collect(),
        residual: def.outputs.clone(),
        constants: def.constants.clone(),
        blocks: def.blocks.clone(),
        define: def.define.clone(),
        coefficients,
    })
}

/// A [`UserModel::new`](crate::model::user::UserModel::new) message about the model of a
/// transfer matrix, in the terms of its table: `coefficients.<o>.<i>` is `h.<o>.<i>`, and `data`
/// and `residual` are the inputs and outputs.
pub fn user_error(msg: &str) -> String {
    msg.replacen("user model", "transfer-matrix model", 1)
        .replace("coefficients.", "h.")
        .replace(": data:", ": inputs/outputs:")
        .replace(": residual:", ": outputs:")
}
