//! `firn presets`: the built-in snow materials.

use firn_core::Material;

/// Prints every preset with its parameters and derived Lamé constants.
pub fn print_presets() {
    outln!(
        "{:<8} {:>10} {:>6} {:>6} {:>9} {:>9} {:>8} {:>10} {:>10}",
        "preset",
        "E [Pa]",
        "nu",
        "xi",
        "theta_c",
        "theta_s",
        "rho0",
        "mu0 [Pa]",
        "lambda0"
    );
    for material in Material::presets() {
        let (mu, lambda) = material.lame();
        outln!(
            "{:<8} {:>10.3e} {:>6} {:>6} {:>9.2e} {:>9.2e} {:>8} {:>10.3e} {:>10.3e}",
            material.name,
            material.youngs_modulus,
            material.poisson_ratio,
            material.hardening,
            material.critical_compression,
            material.critical_stretch,
            material.density,
            mu,
            lambda
        );
    }
    outln!(
        "\nsnow = Stomakhin et al. 2013, Table 2 (rho0 = 400); thesis = the thesis' test scene, §6.3."
    );
    outln!("Override any parameter in a [materials.NAME] table; see docs/scene-format.md.");
}
