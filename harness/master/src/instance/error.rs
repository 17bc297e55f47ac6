//! What an [`FmuInstance`](super::FmuInstance) call answers: a completed step's outcome, or why a
//! call did not succeed, with the FMU's own last words.

use super::ParameterValue;
use crate::fmu::VariableType;

/// How a communication step the FMU accepted ended (the status of fmi2DoStep, FMI 2.0 section
/// 4.2.2, or fmi3DoStep); Discard, Error and Fatal are an [`InstanceError::Call`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepOutcome {
    /// fmi2OK / fmi3OK.
    Ok,
    /// fmi2Warning / fmi3Warning: the step was done and the FMU logged a reason.
    Warning,
    /// fmi2Pending (FMI 2.0 only): the FMU computes the step asynchronously. Only an FMU that
    /// declares `canRunAsynchronuously` may answer it.
    Pending,
}

/// Why a call on an FMU instance did not succeed. Each message names the bad input or the call
/// and what the FMU answered; the caller adds which FMU and run it was.
#[derive(Debug, thiserror::Error)]
pub enum InstanceError {
    /// The FMU answered Discard, Error or Fatal, or the call could not be made.
    #[error("{call} failed ({status}){}", quoted(logged))]
    Call {
        /// The FMI function (or what was being set) with its arguments.
        call: String,
        /// The FMU's status, or why the call could not be made.
        status: String,
        /// The FMU's last log messages for this instance, oldest first.
        logged: Vec<String>,
    },
    /// A name that is no variable of the wanted kind.
    #[error("no {wanted} named {name:?}; it has {known}")]
    NoVariable {
        name: String,
        /// "parameter or input", "Real input", ...
        wanted: &'static str,
        /// The names of that kind it has, sorted, comma-separated.
        known: String,
    },
    /// A value whose type the variable does not take.
    #[error("{name:?} is a {var_type:?} variable; {value:?} does not fit")]
    WrongType {
        name: String,
        var_type: VariableType,
        value: ParameterValue,
    },
}

/// `; the FMU logged: a | b`, or nothing when it logged nothing.
fn quoted(logged: &[String]) -> String {
    if logged.is_empty() {
        String::new()
    } else {
        format!("; the FMU logged: {}", logged.join(" | "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_call_quotes_what_the_fmu_logged_and_only_then() {
        let call = |logged: Vec<String>| InstanceError::Call {
            call: "fmi2DoStep(t = 1 s, h = 0.01 s)".into(),
            status: "Discard".into(),
            logged,
        };
        assert_eq!(
            call(Vec::new()).to_string(),
            "fmi2DoStep(t = 1 s, h = 0.01 s) failed (Discard)"
        );
        assert_eq!(
            call(vec!["ERROR: a".into(), "ERROR: b".into()]).to_string(),
            "fmi2DoStep(t = 1 s, h = 0.01 s) failed (Discard); the FMU logged: ERROR: a | ERROR: b"
        );
    }
}
