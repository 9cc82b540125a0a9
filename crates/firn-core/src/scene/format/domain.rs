//! Reads and checks the `[domain]` table: the simulated box, its grid and its walls.

use glam::Vec3;
use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::values::{
    AXES, Num, finite_vec, not_negative, positive, require, round_up_3_digits, vec3,
};
use crate::scene::model::{Contact, ContactMode, Domain};

/// Largest number of grid cells allowed along one axis.
pub const MAX_CELLS_PER_AXIS: u64 = 1024;

/// Largest total number of grid cells allowed (2^30, a 1024³ box). The
/// solver's grid is sparse: the box costs a page table of 4 bytes per 4³
/// block (64 MiB at 1024³), node storage follows the snow.
pub const MAX_CELLS: u64 = 1 << 30;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawDomain {
    pub(super) min: Option<[f32; 3]>,
    pub(super) max: Option<[f32; 3]>,
    pub(super) cell_size: Option<f32>,
    pub(super) walls: Option<RawContact>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawContact {
    pub(super) mode: Option<RawMode>,
    pub(super) friction: Option<f32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawMode {
    Sticky,
    Slip,
    Separate,
}

/// The `[domain]` table, which every snow scene needs.
pub(super) fn resolve_domain(raw: Option<RawDomain>) -> Result<Domain, Issue> {
    let domain_path = KeyPath::of("domain");
    let raw_domain = raw.ok_or_else(|| {
        Issue::new(
            domain_path.clone(),
            "the scene has no [domain] table",
            "add a [domain] table with max and cell_size, e.g. [domain] max = [2.0, 2.0, 2.0] \
             cell_size = 0.02",
        )
    })?;
    Ok(Domain {
        walls: contact(raw_domain.walls),
        ..Domain::new(
            raw_domain.min.map_or(Vec3::ZERO, vec3),
            vec3(require(
                raw_domain.max,
                domain_path.key("max"),
                "the upper corner",
            )?),
            require(
                raw_domain.cell_size,
                domain_path.key("cell_size"),
                "the grid spacing in metres",
            )?,
        )
    })
}

/// A contact table over [`Contact::default`].
pub(super) fn contact(raw: Option<RawContact>) -> Contact {
    contact_over(raw, Contact::default())
}

/// A contact table over `defaults`.
pub(super) fn contact_over(raw: Option<RawContact>, defaults: Contact) -> Contact {
    let Some(raw) = raw else {
        return defaults;
    };
    Contact {
        mode: match raw.mode {
            Some(RawMode::Sticky) => ContactMode::Sticky,
            Some(RawMode::Slip) => ContactMode::Slip,
            Some(RawMode::Separate) => ContactMode::Separate,
            None => defaults.mode,
        },
        friction: raw.friction.unwrap_or(defaults.friction),
    }
}

pub(super) fn check_contact(path: &KeyPath, contact: &Contact) -> Check {
    not_negative(
        contact.friction,
        path.key("friction"),
        "set the Coulomb friction coefficient, e.g. friction = 0.2 (0: frictionless)".to_string(),
    )
}

pub(super) fn check_domain(domain: &Domain) -> Check {
    let path = KeyPath::of("domain");
    finite_vec(domain.min, path.key("min"))?;
    finite_vec(domain.max, path.key("max"))?;
    for (axis, name) in AXES.iter().enumerate() {
        if domain.max[axis] <= domain.min[axis] {
            return Err(Issue::new(
                path.key("max"),
                format!(
                    "domain.max must be greater than domain.min on every axis, but along {name} \
                     max = {} and min = {}",
                    Num::from(domain.max[axis]),
                    Num::from(domain.min[axis])
                ),
                "give the upper corner of the box, e.g. min = [0.0, 0.0, 0.0] and \
                 max = [2.0, 2.0, 2.0]",
            ));
        }
    }
    positive(
        domain.cell_size,
        path.key("cell_size"),
        "set cell_size to the grid spacing in metres, e.g. cell_size = 0.02".to_string(),
    )?;
    let extent = (domain.max - domain.min).as_dvec3();
    let h = f64::from(domain.cell_size);
    let cells = [extent.x, extent.y, extent.z].map(|e| (e / h - 1e-4).ceil().max(1.0));
    for (axis, name) in AXES.iter().enumerate() {
        if cells[axis] > MAX_CELLS_PER_AXIS as f64 {
            let smallest = round_up_3_digits(extent[axis] / MAX_CELLS_PER_AXIS as f64);
            return Err(Issue::new(
                path.key("cell_size"),
                format!(
                    "the grid would have {} cells along {name} (the limit is \
                     {MAX_CELLS_PER_AXIS})",
                    cells[axis]
                ),
                format!(
                    "use a larger cell_size (at least {smallest} for this domain) or a \
                     smaller domain"
                ),
            ));
        }
    }
    let total = cells[0] * cells[1] * cells[2];
    if total > MAX_CELLS as f64 {
        return Err(Issue::new(
            path.key("cell_size"),
            format!(
                "the grid would have {total} cells ({} x {} x {}; the limit is 2^30 = {MAX_CELLS})",
                cells[0], cells[1], cells[2]
            ),
            "use a larger cell_size or a smaller domain",
        ));
    }
    check_contact(&path.key("walls"), &domain.walls)
}
