//! Vehicle models A (single-track, HSRI), B (two-track, Magic Formula) and C (rear-axle single-track); no FMI code
