//! Reads and checks the `[materials.NAME]` tables: presets and their overrides.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::messages::closest;
use super::values::{Num, ensure, not_negative, positive};
use crate::scene::material::{Material, PRESET_NAMES};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMaterial {
    preset: Option<String>,
    youngs_modulus: Option<f32>,
    poisson_ratio: Option<f32>,
    hardening: Option<f32>,
    critical_compression: Option<f32>,
    critical_stretch: Option<f32>,
    density: Option<f32>,
}

/// Expand every `[materials.NAME]` table over its preset and check it, used
/// or not.
pub(super) fn resolve_materials(
    raw: BTreeMap<String, RawMaterial>,
) -> Result<BTreeMap<String, Material>, Issue> {
    let mut declared = BTreeMap::new();
    for (name, raw_material) in raw {
        let path = KeyPath::of("materials").key(&name);
        // The base: the named preset, else the preset this table overrides,
        // else snow.
        let base_name = match &raw_material.preset {
            Some(preset) => preset.clone(),
            None if PRESET_NAMES.contains(&name.as_str()) => name.clone(),
            None => Material::DEFAULT_PRESET.to_string(),
        };
        let base = Material::preset(&base_name).ok_or_else(|| {
            let mut hint = String::new();
            if let Some(best) = closest(&base_name, &PRESET_NAMES) {
                hint.push_str(&format!("did you mean \"{best}\"? "));
            }
            hint.push_str(&format!("the presets are {}", PRESET_NAMES.join(", ")));
            Issue::new(
                path.key("preset"),
                format!("{path}.preset names no preset \"{base_name}\""),
                hint,
            )
        })?;
        let material = Material {
            name: name.clone(),
            youngs_modulus: raw_material.youngs_modulus.unwrap_or(base.youngs_modulus),
            poisson_ratio: raw_material.poisson_ratio.unwrap_or(base.poisson_ratio),
            hardening: raw_material.hardening.unwrap_or(base.hardening),
            critical_compression: raw_material
                .critical_compression
                .unwrap_or(base.critical_compression),
            critical_stretch: raw_material
                .critical_stretch
                .unwrap_or(base.critical_stretch),
            density: raw_material.density.unwrap_or(base.density),
        };
        check_material(&path, &material)?;
        declared.insert(name, material);
    }
    Ok(declared)
}

pub(super) fn unknown_material(
    body: &KeyPath,
    name: &str,
    declared: &BTreeMap<String, Material>,
) -> Issue {
    let mut known: Vec<&str> = PRESET_NAMES.to_vec();
    for declared_name in declared.keys() {
        if !known.contains(&declared_name.as_str()) {
            known.push(declared_name);
        }
    }
    let mut hint = String::new();
    if let Some(best) = closest(name, &known) {
        hint.push_str(&format!("did you mean \"{best}\"? "));
    }
    hint.push_str(&format!(
        "known materials: {}; or define it in a [materials.{}] table",
        known.join(", "),
        KeyPath::of(name)
    ));
    Issue::new(
        body.key("material"),
        format!("{body}.material names an unknown material \"{name}\""),
        hint,
    )
}

/// The constitutive parameter ranges (Stomakhin et al. 2013).
pub(super) fn check_material(path: &KeyPath, material: &Material) -> Check {
    positive(
        material.youngs_modulus,
        path.key("youngs_modulus"),
        "set Young's modulus E in pascals, e.g. youngs_modulus = 1.4e5".to_string(),
    )?;
    let nu = material.poisson_ratio;
    if nu <= -1.0 || nu.is_nan() {
        return Err(Issue::new(
            path.key("poisson_ratio"),
            format!(
                "{path}.poisson_ratio must be greater than -1 (got {}): the shear modulus \
                 μ = E/(2(1+ν)) would not be positive",
                Num::from(nu)
            ),
            "use a value like 0.3 (snow: 0.2)",
        ));
    }
    if nu >= 0.5 {
        return Err(Issue::new(
            path.key("poisson_ratio"),
            format!(
                "{path}.poisson_ratio must be less than 0.5 (got {}): the Lamé parameter \
                 λ = Eν/((1+ν)(1-2ν)) becomes infinite at 0.5 and negative above it",
                Num::from(nu)
            ),
            "use a value like 0.3 (snow: 0.2)",
        ));
    }
    not_negative(
        material.hardening,
        path.key("hardening"),
        "set the hardening coefficient ξ, e.g. hardening = 10.0 (0: no hardening)".to_string(),
    )?;
    ensure(
        (0.0..1.0).contains(&material.critical_compression),
        path.key("critical_compression"),
        "in [0, 1)",
        Num::from(material.critical_compression),
        "set θc, how far snow compresses before it yields, e.g. critical_compression = 0.025"
            .to_string(),
    )?;
    not_negative(
        material.critical_stretch,
        path.key("critical_stretch"),
        "set θs, how far snow stretches before it yields, e.g. critical_stretch = 0.0075"
            .to_string(),
    )?;
    positive(
        material.density,
        path.key("density"),
        "set the initial density ρ0 in kg/m³, e.g. density = 400.0".to_string(),
    )
}
