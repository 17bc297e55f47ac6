//! Reads and checks modelDescription.xml; generates the FMU crates' value-reference tables at build time
