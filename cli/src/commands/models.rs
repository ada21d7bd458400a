//! `stiction models`: what is registered.

use anyhow::Context;
use serde_json::json;
use stiction_models::registry;

fn linear_json() -> Vec<serde_json::Value> {
    linear_id::registry()
        .iter()
        .map(|e| {
            json!({
                "name": e.name,
                "description": e.description,
                "orders": e.orders.iter().map(|o| json!({
                    "name": o.name, "default": o.default, "meaning": o.meaning,
                })).collect::<Vec<_>>(),
            })
        })
        .collect()
}

use crate::{data, CmdResult, Streams};

/// Arguments of `stiction models`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args, s: &mut Streams<'_>) -> CmdResult {
    let stiction = registry();
    if args.json {
        let doc = json!({
            "stiction": stiction.iter().map(|e| json!({
                "name": e.name,
                "description": e.description,
                "params": e.params.iter().map(|p| json!({
                    "name": p.name,
                    "meaning": p.meaning,
                    "default": p.default,
                    "max_span_fraction": p.max_span_fraction,
                })).collect::<Vec<_>>(),
                "constraints": e.constraints.iter().map(|c| c.describe()).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "linear": linear_json(),
        });
        serde_json::to_writer_pretty(&mut *s.stdout, &doc)
            .context("writing JSON")
            .map_err(data)?;
        writeln!(s.stdout).map_err(data)?;
        return Ok(());
    }
    let out = &mut *s.stdout;
    writeln!(
        out,
        "Stiction models (OP -> MV); parameters in OP units (% of valve span):"
    )
    .map_err(data)?;
    for e in &stiction {
        let params: Vec<&str> = e.params.iter().map(|p| p.name).collect();
        let constraints: Vec<String> = e.constraints.iter().map(|c| c.describe()).collect();
        let constraints = if constraints.is_empty() {
            String::new()
        } else {
            format!("  [{}]", constraints.join("; "))
        };
        writeln!(out, "  {:<11} {}{constraints}", e.name, params.join(", ")).map_err(data)?;
        writeln!(out, "  {:<11} {}", "", e.description).map_err(data)?;
    }
    writeln!(
        out,
        "\nLinear identifiers (MV -> PV); orders with their defaults:"
    )
    .map_err(data)?;
    for e in linear_id::registry() {
        let orders: Vec<String> = e
            .orders
            .iter()
            .map(|o| format!("{}={}", o.name, o.default))
            .collect();
        writeln!(out, "  {:<11} {}", e.name, orders.join(", ")).map_err(data)?;
        writeln!(out, "  {:<11} {}", "", e.description).map_err(data)?;
    }
    Ok(())
}
