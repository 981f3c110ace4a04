//! `lucid brdf`: measured BRDF tables — tabulating a scene file's material, and the PCA basis
//! of a set of tables with a fit of another table in it.

use std::path::Path;

use anyhow::Context;
use lucid_trace::bsdf::measured::MerlTable;
use lucid_trace::bsdf::measured_pca::{BrdfPca, relative_rms};

use super::refuse_existing;
use crate::cli::BrdfCommand;

pub fn run(command: BrdfCommand) -> anyhow::Result<()> {
    match command {
        BrdfCommand::Tabulate { scene, material, output } => tabulate(&scene, &material, &output),
        BrdfCommand::Pca { tables, k, fit, output } => pca(&tables, k, fit.as_deref(), output.as_deref()),
        BrdfCommand::FitNeural { table, output, steps, layers, width, batch, seed } => {
            refuse_existing(&output)?;
            let settings = super::brdf_neural::FitSettings { steps, layers, width, batch, seed, progress: true };
            super::brdf_neural::fit(&table, &output, &settings)
        }
    }
}

fn tabulate(scene: &Path, name: &str, output: &Path) -> anyhow::Result<()> {
    refuse_existing(output)?;
    let text = std::fs::read_to_string(scene).with_context(|| format!("reading {}", scene.display()))?;
    let table: toml::Table = toml::from_str(&text).with_context(|| format!("{}: not TOML", scene.display()))?;
    let mut names: Vec<&String> =
        table.get("materials").and_then(|m| m.as_table()).map(|m| m.keys().collect()).unwrap_or_default();
    // The scene keeps its materials in name order.
    names.sort();
    let index = names
        .iter()
        .position(|n| n.as_str() == name)
        .with_context(|| format!("{}: no material {name:?} (it has {names:?})", scene.display()))?;
    let loaded = lucid_trace::load_scene(scene)?;
    let material = &loaded.scene.materials[index];
    let started = std::time::Instant::now();
    let merl = lucid_trace::tabulate::tabulate(material)
        .with_context(|| format!("{}: material {name:?} has no table", scene.display()))?;
    merl.write(output)?;
    println!(
        "tabulated {name} of {} into {} in {:.1} s",
        scene.display(),
        output.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn pca(paths: &[std::path::PathBuf], k: usize, fit: Option<&Path>, output: Option<&Path>) -> anyhow::Result<()> {
    if let Some(out) = output {
        refuse_existing(out)?;
    }
    let tables: Vec<MerlTable> = paths.iter().map(|p| MerlTable::read(p)).collect::<Result<_, _>>()?;
    let refs: Vec<&MerlTable> = tables.iter().collect();
    let basis = BrdfPca::fit(&refs, k).map_err(|e| anyhow::anyhow!("pca: {e}"))?;
    let total: f64 = basis.variances().iter().sum();
    println!("{} components of {} tables (variance of each, share of the kept total):", basis.len(), tables.len());
    for (i, v) in basis.variances().iter().enumerate() {
        println!("  {:>2}: {v:.4e} ({:.1} %)", i + 1, 100.0 * v / total);
    }
    println!("{:<40} {:>22}", "table", "relative RMS error");
    for (path, table) in paths.iter().zip(&tables) {
        let error = relative_rms(&basis.reconstruct(table), table);
        println!("{:<40} {error:>22.4}", path.display());
    }
    if let (Some(fit), Some(out)) = (fit, output) {
        let target = MerlTable::read(fit)?;
        let fitted = basis.reconstruct(&target);
        fitted.write(out)?;
        println!(
            "fitted {} (relative RMS error {:.4}), written to {}",
            fit.display(),
            relative_rms(&fitted, &target),
            out.display()
        );
    }
    Ok(())
}
