//! Prints a built-in model as a TOML robot file in the general joint form:
//! `cargo run -p dynamics --example write_robot_toml -- lwr4|lwr4-mdh|planar-2r`.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let which = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "lwr4".to_string());
    let text = match which.as_str() {
        "lwr4" => dynamics::lwr4().to_toml_string()?,
        "lwr4-mdh" => dynamics::lwr4_modified_dh().to_toml_string()?,
        "planar-2r" => dynamics::planar_2r().to_toml_string()?,
        other => return Err(format!("unknown model `{other}` (lwr4, lwr4-mdh, planar-2r)").into()),
    };
    print!("{text}");
    Ok(())
}
