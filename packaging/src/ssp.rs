//! The SSP 1.0 system `VehicleWithEstimator`: the reference vehicle feeding the estimator.
//!
//! Connections go by name: every ReferenceVehicle output whose name is also a VehicleStateEstimator
//! input is connected, and the driver inputs are system inputs connected to both components.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use anyhow::{bail, Result};
use quick_xml::escape::escape;

use crate::description::{ModelDescription, ScalarVariable};

/// Driver inputs that both FMUs take and the system exposes as its own inputs.
pub const DRIVER_INPUTS: [&str; 3] = ["steering_angle", "drive_torque", "brake_torque"];

pub const SYSTEM_NAME: &str = "VehicleWithEstimator";

const SSD_NAMESPACE: &str = "http://ssp-standard.org/SSP1/SystemStructureDescription";
const SSC_NAMESPACE: &str = "http://ssp-standard.org/SSP1/SystemStructureCommon";

/// One SSD connection; `None` as element means the enclosing system's own connector.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Connection {
    pub start_element: Option<String>,
    pub start_connector: String,
    pub end_element: Option<String>,
    pub end_connector: String,
}

/// The connection plan of the system, computed from the two model descriptions.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SystemPlan {
    pub vehicle: String,
    pub estimator: String,
    pub connections: Vec<Connection>,
    /// Estimator inputs no ReferenceVehicle output provides; they keep their start values and get
    /// no connector (SSP connectors of component inputs are expected to be connected).
    pub unconnected_estimator_inputs: Vec<String>,
}

impl SystemPlan {
    /// Inputs of `element` that some connection ends in.
    pub fn connected_inputs(&self, element: &str) -> Vec<&str> {
        self.connections
            .iter()
            .filter(|c| c.end_element.as_deref() == Some(element))
            .map(|c| c.end_connector.as_str())
            .collect()
    }
}

fn require_real_input(description: &ModelDescription, name: &str) -> Result<()> {
    match description.variable(name) {
        Some(variable) if variable.causality == "input" && variable.type_name == "Real" => Ok(()),
        Some(variable) => bail!(
            "{}: {name:?} must be a Real input to be a system input of {SYSTEM_NAME}, but it is a \
             {} {}",
            description.file.display(),
            variable.type_name,
            variable.causality
        ),
        None => bail!(
            "{}: has no input {name:?}, which {SYSTEM_NAME} connects to the driver input",
            description.file.display()
        ),
    }
}

/// Works out the connections; fails when a name matches but causality or type do not fit.
pub fn plan(vehicle: &ModelDescription, estimator: &ModelDescription) -> Result<SystemPlan> {
    let vehicle_id = vehicle.model_identifier.clone();
    let estimator_id = estimator.model_identifier.clone();
    if vehicle_id == estimator_id {
        bail!("both FMUs have the model identifier {vehicle_id:?}; component names must differ");
    }
    for name in DRIVER_INPUTS {
        require_real_input(vehicle, name)?;
        require_real_input(estimator, name)?;
    }
    let mut connections = Vec::new();
    for name in DRIVER_INPUTS {
        for element in [&vehicle_id, &estimator_id] {
            connections.push(Connection {
                start_element: None,
                start_connector: name.to_string(),
                end_element: Some(element.clone()),
                end_connector: name.to_string(),
            });
        }
    }
    let mut unconnected = Vec::new();
    for input in estimator.variables_with_causality("input") {
        if DRIVER_INPUTS.contains(&input.name.as_str()) {
            continue;
        }
        match vehicle.variable(&input.name) {
            Some(output) if output.causality == "output" => {
                if output.type_name != input.type_name {
                    bail!(
                        "{} output {:?} is {} but {} input {:?} is {}; a connection by name needs \
                         equal types",
                        vehicle_id,
                        output.name,
                        output.type_name,
                        estimator_id,
                        input.name,
                        input.type_name
                    );
                }
                let output_unit = vehicle.effective_unit(output);
                let input_unit = estimator.effective_unit(input);
                if output_unit != input_unit {
                    bail!(
                        "{} output {:?} has unit {:?} but {} input {:?} has unit {:?}",
                        vehicle_id,
                        output.name,
                        output_unit,
                        estimator_id,
                        input.name,
                        input_unit
                    );
                }
                connections.push(Connection {
                    start_element: Some(vehicle_id.clone()),
                    start_connector: output.name.clone(),
                    end_element: Some(estimator_id.clone()),
                    end_connector: input.name.clone(),
                });
            }
            _ => unconnected.push(input.name.clone()),
        }
    }
    Ok(SystemPlan {
        vehicle: vehicle_id,
        estimator: estimator_id,
        connections,
        unconnected_estimator_inputs: unconnected,
    })
}

fn attribute(name: &str, value: &str) -> String {
    format!(" {name}=\"{}\"", escape(value))
}

/// The `ssc:` type element of a connector, or nothing where the FMU's own type is authoritative
/// (enumerations would need an SSD enumeration declaration).
fn connector_type(description: &ModelDescription, variable: &ScalarVariable) -> String {
    match variable.type_name.as_str() {
        "Real" => match description.effective_unit(variable) {
            Some(unit) => format!("<ssc:Real{}/>", attribute("unit", &unit)),
            None => "<ssc:Real/>".into(),
        },
        "Integer" => "<ssc:Integer/>".into(),
        "Boolean" => "<ssc:Boolean/>".into(),
        "String" => "<ssc:String/>".into(),
        _ => String::new(),
    }
}

fn connector(out: &mut String, indent: &str, name: &str, kind: &str, type_element: &str) {
    if type_element.is_empty() {
        let _ = writeln!(
            out,
            "{indent}<ssd:Connector{}{}/>",
            attribute("name", name),
            attribute("kind", kind)
        );
    } else {
        let _ = writeln!(
            out,
            "{indent}<ssd:Connector{}{}>{type_element}</ssd:Connector>",
            attribute("name", name),
            attribute("kind", kind)
        );
    }
}

fn component(
    out: &mut String,
    description: &ModelDescription,
    connected_inputs: &[&str],
    units: &mut BTreeMap<String, Vec<(String, String)>>,
) -> Result<()> {
    let id = &description.model_identifier;
    let _ = writeln!(
        out,
        "      <ssd:Component{}{}{}>",
        attribute("name", id),
        attribute("type", "application/x-fmu-sharedlibrary"),
        attribute("source", &format!("resources/{id}.fmu"))
    );
    out.push_str("        <ssd:Connectors>\n");
    // Document order of the FMU's variables: inputs that are connected, then every output.
    for variable in &description.variables {
        let listed = match variable.causality.as_str() {
            "input" => connected_inputs.contains(&variable.name.as_str()),
            "output" => true,
            _ => false,
        };
        if !listed {
            continue;
        }
        if let Some(unit) = description.effective_unit(variable) {
            let base = description
                .unit_definition(&unit)
                .map(|u| u.base_unit.clone())
                .unwrap_or_default();
            match units.get(&unit) {
                Some(known) if *known != base => bail!(
                    "unit {unit:?} has different BaseUnit definitions in the two model \
                     descriptions ({} has {:?})",
                    description.file.display(),
                    base
                ),
                Some(_) => {}
                None => {
                    units.insert(unit, base);
                }
            }
        }
        connector(
            out,
            "          ",
            &variable.name,
            &variable.causality,
            &connector_type(description, variable),
        );
    }
    out.push_str("        </ssd:Connectors>\n");
    out.push_str("      </ssd:Component>\n");
    Ok(())
}

/// The text of `SystemStructure.ssd`.
pub fn system_structure(
    vehicle: &ModelDescription,
    estimator: &ModelDescription,
    plan: &SystemPlan,
    generation_tool: &str,
) -> Result<String> {
    let mut units: BTreeMap<String, Vec<(String, String)>> = BTreeMap::new();
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        out,
        "<ssd:SystemStructureDescription xmlns:ssd=\"{SSD_NAMESPACE}\" xmlns:ssc=\"{SSC_NAMESPACE}\"{}{}{}>",
        attribute("version", "1.0"),
        attribute("name", SYSTEM_NAME),
        attribute("generationTool", generation_tool)
    );
    let _ = writeln!(
        out,
        "  <ssd:System{}{}>",
        attribute("name", SYSTEM_NAME),
        attribute(
            "description",
            &format!(
                "{} drives {}: the driver inputs go to both, every {} output named like a {} \
                 input feeds it.",
                plan.vehicle, plan.estimator, plan.vehicle, plan.estimator
            )
        )
    );
    out.push_str("    <ssd:Connectors>\n");
    for name in DRIVER_INPUTS {
        let variable = vehicle
            .variable(name)
            .expect("plan() checked that the driver inputs exist");
        connector(
            &mut out,
            "      ",
            name,
            "input",
            &connector_type(vehicle, variable),
        );
    }
    out.push_str("    </ssd:Connectors>\n");
    out.push_str("    <ssd:Elements>\n");
    component(
        &mut out,
        vehicle,
        &plan.connected_inputs(&plan.vehicle),
        &mut units,
    )?;
    component(
        &mut out,
        estimator,
        &plan.connected_inputs(&plan.estimator),
        &mut units,
    )?;
    out.push_str("    </ssd:Elements>\n");
    out.push_str("    <ssd:Connections>\n");
    for connection in &plan.connections {
        let mut attributes = String::new();
        if let Some(element) = &connection.start_element {
            attributes += &attribute("startElement", element);
        }
        attributes += &attribute("startConnector", &connection.start_connector);
        if let Some(element) = &connection.end_element {
            attributes += &attribute("endElement", element);
        }
        attributes += &attribute("endConnector", &connection.end_connector);
        let _ = writeln!(out, "      <ssd:Connection{attributes}/>");
    }
    out.push_str("    </ssd:Connections>\n");
    out.push_str("  </ssd:System>\n");
    if !units.is_empty() {
        out.push_str("  <ssd:Units>\n");
        for (name, base) in &units {
            let base_attributes: String = base
                .iter()
                .map(|(key, value)| attribute(key, value))
                .collect();
            let _ = writeln!(
                out,
                "    <ssc:Unit{}><ssc:BaseUnit{base_attributes}/></ssc:Unit>",
                attribute("name", name)
            );
        }
        out.push_str("  </ssd:Units>\n");
    }
    let experiment: String = vehicle
        .default_experiment
        .iter()
        .filter(|(key, _)| key == "startTime" || key == "stopTime")
        .map(|(key, value)| attribute(key, value))
        .collect();
    if !experiment.is_empty() {
        let _ = writeln!(out, "  <ssd:DefaultExperiment{experiment}/>");
    }
    out.push_str("</ssd:SystemStructureDescription>\n");
    Ok(out)
}
