//! The SSP 1.0 system `VehicleWithEstimator`: the reference vehicle feeding the estimator.
//!
//! Connections go by name: every ReferenceVehicle output whose name is also a VehicleStateEstimator
//! input is connected. Every connection runs from a component to a component (`startElement` and
//! `endElement` set): libcosim's SSP loader (`ssp_parser.cpp`, Open Simulation Platform) and Ecos
//! refuse a connection from a system connector, so the system has no connectors of its own. The
//! driver inputs of both FMUs instead get their values from one parameter set bound to both
//! components, [`DRIVER_FILE`] (SSP 1.0 section 5.3.5; a parameter set may set inputs), which holds
//! them constant. The default experiment carries the step size as the Open Simulation Platform
//! annotation libcosim reads (`osp:FixedStepAlgorithm baseStepSize`); SSP 1.0 has no step-size
//! attribute.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use anyhow::{bail, Result};
use quick_xml::escape::escape;

use crate::description::{ModelDescription, ScalarVariable};

/// Driver inputs that both FMUs take; [`DRIVER_FILE`] sets them on both.
pub const DRIVER_INPUTS: [&str; 3] = ["steering_angle", "drive_torque", "brake_torque"];

/// The parameter-value file (under `resources/`) bound to both components: the driver inputs.
pub const DRIVER_FILE: &str = "driver_inputs.ssv";

/// The values [`DRIVER_FILE`] gives the driver inputs: the seed-000 step-steer angle (2 degrees,
/// 000: fig. 7.18) held from the start, no drive or brake torque, so the default experiment is a
/// steady turn that decelerates slowly (the seed's step steer starts at its steer time instead).
pub const DRIVER_VALUES: [(&str, f64); 3] = [
    ("steering_angle", manoeuvres::seed000::STEP_STEER_ANGLE),
    ("drive_torque", 0.0),
    ("brake_torque", 0.0),
];

pub const SYSTEM_NAME: &str = "VehicleWithEstimator";

const SSD_NAMESPACE: &str = "http://ssp-standard.org/SSP1/SystemStructureDescription";
const SSC_NAMESPACE: &str = "http://ssp-standard.org/SSP1/SystemStructureCommon";
const SSV_NAMESPACE: &str = "http://ssp-standard.org/SSP1/SystemStructureParameterValues";
/// The namespace of the Open Simulation Platform's SSP annotations (libcosim's
/// `tests/data/ssp/OSPAnnotations.xsd`); libcosim matches the `osp:` prefix literally.
const OSP_NAMESPACE: &str = "http://opensimulationplatform.com/SSP/OSPAnnotations";

/// One SSD connection, always from a component's output to a component's input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Connection {
    pub start_element: String,
    pub start_connector: String,
    pub end_element: String,
    pub end_connector: String,
}

/// The connection plan of the system, computed from the two model descriptions.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SystemPlan {
    pub vehicle: String,
    pub estimator: String,
    pub connections: Vec<Connection>,
    /// Estimator inputs no ReferenceVehicle output provides, other than the driver inputs; they
    /// keep their start values and get no connector (SSP connectors of component inputs are
    /// expected to be connected).
    pub unconnected_estimator_inputs: Vec<String>,
}

impl SystemPlan {
    /// Inputs of `element` that some connection ends in.
    pub fn connected_inputs(&self, element: &str) -> Vec<&str> {
        self.connections
            .iter()
            .filter(|c| c.end_element == element)
            .map(|c| c.end_connector.as_str())
            .collect()
    }
}

fn require_real_input(description: &ModelDescription, name: &str) -> Result<()> {
    match description.variable(name) {
        Some(variable) if variable.causality == "input" && variable.type_name == "Real" => Ok(()),
        Some(variable) => bail!(
            "{}: {name:?} must be a Real input for {DRIVER_FILE} of {SYSTEM_NAME} to set it, but \
             it is a {} {}",
            description.file.display(),
            variable.type_name,
            variable.causality
        ),
        None => bail!(
            "{}: has no input {name:?}, which {SYSTEM_NAME} sets from {DRIVER_FILE}",
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
                    start_element: vehicle_id.clone(),
                    start_connector: output.name.clone(),
                    end_element: estimator_id.clone(),
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
    // SSP 1.0 section 5.3.5: the source is relative to the SSD, names to the component.
    out.push_str("        <ssd:ParameterBindings>\n");
    let _ = writeln!(
        out,
        "          <ssd:ParameterBinding{}{}/>",
        attribute("type", "application/x-ssp-parameter-set"),
        attribute("source", &format!("resources/{DRIVER_FILE}"))
    );
    out.push_str("        </ssd:ParameterBindings>\n");
    out.push_str("      </ssd:Component>\n");
    Ok(())
}

/// The text of [`DRIVER_FILE`]: an SSP 1.0 parameter-value file (section 6) with
/// [`DRIVER_VALUES`], units from the ReferenceVehicle's model description; only `ssv:Real`
/// entries, which every SSP runner applies (libcosim aborts on `ssv:Enumeration`).
pub fn driver_parameter_set(vehicle: &ModelDescription, generation_tool: &str) -> Result<String> {
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        out,
        "<ssv:ParameterSet xmlns:ssc=\"{SSC_NAMESPACE}\" xmlns:ssv=\"{SSV_NAMESPACE}\"{}{}{}{}>",
        attribute("version", "1.0"),
        attribute("name", "driver inputs"),
        attribute(
            "description",
            "Driver inputs held constant: the seed-000 step-steer angle (2 degrees) from the \
             start, no drive or brake torque"
        ),
        attribute("generationTool", generation_tool)
    );
    out.push_str("  <ssv:Parameters>\n");
    for (name, value) in DRIVER_VALUES {
        require_real_input(vehicle, name)?;
        let variable = vehicle.variable(name).expect("require_real_input found it");
        let unit = vehicle
            .effective_unit(variable)
            .map(|unit| attribute("unit", &unit))
            .unwrap_or_default();
        // `{:?}` prints the shortest text that reads back as the same f64.
        let _ = writeln!(
            out,
            "    <ssv:Parameter{}><ssv:Real{}{unit}/></ssv:Parameter>",
            attribute("name", name),
            attribute("value", &format!("{value:?}"))
        );
    }
    out.push_str("  </ssv:Parameters>\n");
    out.push_str("</ssv:ParameterSet>\n");
    Ok(out)
}

/// `ssd:DefaultExperiment` from the ReferenceVehicle's DefaultExperiment: start and stop time,
/// and its step size as the `com.opensimulationplatform` annotation libcosim reads.
fn default_experiment(out: &mut String, vehicle: &ModelDescription) {
    let value = |key: &str| {
        vehicle
            .default_experiment
            .iter()
            .find(|(name, _)| name == key)
            .map(|(_, value)| value.clone())
    };
    let times: String = ["startTime", "stopTime"]
        .iter()
        .filter_map(|key| value(key).map(|v| attribute(key, &v)))
        .collect();
    let Some(step) = value("stepSize") else {
        if !times.is_empty() {
            let _ = writeln!(out, "  <ssd:DefaultExperiment{times}/>");
        }
        return;
    };
    let _ = writeln!(out, "  <ssd:DefaultExperiment{times}>");
    out.push_str("    <ssd:Annotations>\n");
    out.push_str("      <ssc:Annotation type=\"com.opensimulationplatform\">\n");
    out.push_str("        <osp:Algorithm>\n");
    let _ = writeln!(
        out,
        "          <osp:FixedStepAlgorithm{}/>",
        attribute("baseStepSize", &step)
    );
    out.push_str("        </osp:Algorithm>\n");
    out.push_str("      </ssc:Annotation>\n");
    out.push_str("    </ssd:Annotations>\n");
    out.push_str("  </ssd:DefaultExperiment>\n");
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
        "<ssd:SystemStructureDescription xmlns:ssd=\"{SSD_NAMESPACE}\" xmlns:ssc=\"{SSC_NAMESPACE}\" \
         xmlns:osp=\"{OSP_NAMESPACE}\"{}{}{}>",
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
                "{} drives {}: every {} output named like a {} input feeds it; {} sets the \
                 driver inputs of both.",
                plan.vehicle, plan.estimator, plan.vehicle, plan.estimator, DRIVER_FILE
            )
        )
    );
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
        let attributes = attribute("startElement", &connection.start_element)
            + &attribute("startConnector", &connection.start_connector)
            + &attribute("endElement", &connection.end_element)
            + &attribute("endConnector", &connection.end_connector);
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
    default_experiment(&mut out, vehicle);
    out.push_str("</ssd:SystemStructureDescription>\n");
    Ok(out)
}
