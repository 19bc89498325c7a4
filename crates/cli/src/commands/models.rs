//! `airsus models`: the model registry — every model by name with its parameters (units,
//! bounds, reference values) and states.

use airsus_truck::models::describe_models;

/// List the models airsus builds by name, with their parameters and states.
#[derive(Debug, Clone, clap::Args)]
pub struct ModelsArgs {
    /// Print a JSON array, one object per model: name, description, parameters (name, unit,
    /// min, max, default, description, needs: what data determine it), states (name, unit,
    /// role) and the default free parameters of a grey-box fit.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &ModelsArgs) -> anyhow::Result<()> {
    let models = describe_models()?;
    if args.json {
        let array: Vec<serde_json::Value> = models
            .iter()
            .map(|m| {
                serde_json::json!({
                    "name": m.name,
                    "description": m.description,
                    "summary": m.summary,
                    "parameters": m.parameters.iter().map(|p| serde_json::json!({
                        "name": p.info.name,
                        "unit": p.info.unit,
                        "min": p.info.lower,
                        "max": p.info.upper,
                        "default": p.default,
                        "description": p.info.description,
                        "needs": p.info.needs,
                    })).collect::<Vec<_>>(),
                    "states": m.states.iter().map(|s| serde_json::json!({
                        "name": s.name,
                        "unit": s.unit,
                        "role": s.role.as_str(),
                    })).collect::<Vec<_>>(),
                    "default_free": m.default_free,
                    "valve_free": m.valve_free,
                    "road_free": m.road_free,
                    "road_refit": m.road_refit,
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&array)?);
        return Ok(());
    }
    for m in &models {
        println!("{:<6} {}", m.name, m.summary);
        println!(
            "       free by default: {}; with valve action also {}{}",
            m.default_free.join(","),
            m.valve_free.join(","),
            if m.road_free.is_empty() {
                String::new()
            } else {
                format!("; with road input also {}", m.road_free.join(","))
            }
        );
        if !m.road_refit.is_empty() {
            println!(
                "       the study refits {} on the road runs alone after the joint estimate",
                m.road_refit.join(",")
            );
        }
        println!(
            "       states: {}",
            m.states
                .iter()
                .map(|s| format!("{} ({})", s.name, s.role.as_str()))
                .collect::<Vec<_>>()
                .join(", ")
        );
        println!(
            "       {:<7} {:>12} {:>12} {:>12}  {:<9} description",
            "param", "reference", "min", "max", "unit"
        );
        for p in &m.parameters {
            println!(
                "       {:<7} {:>12} {:>12} {:>12}  {:<9} {}",
                p.info.name,
                format!("{:.6e}", p.default),
                format!("{:.3e}", p.info.lower),
                format!("{:.3e}", p.info.upper),
                p.info.unit,
                p.info.description
            );
        }
        println!();
    }
    Ok(())
}
