//! Named materials of Mitsuba's `conductor`/`roughconductor` (`material="Au"`) and named
//! indices of refraction of its dielectric plugins (`int_ior="bk7"`).
//!
//! The conductors' RGB η and κ are the spectral tables Mitsuba ships (from Palik, *Handbook of
//! Optical Constants of Solids*, 1985, and Weaver et al., *Physics Data: Optical Properties of
//! Metals*, 1981) reduced to linear sRGB primaries, as tabulated by Bitterli's Tungsten renderer
//! (`ComplexIorData.hpp`), rounded to 6 digits. Mitsuba 3 reduces the same spectra itself in
//! its RGB variants, so its values may differ in the last digits. Only the entries with η > 0
//! and κ ≥ 0 in all three channels are listed (the Cook–Torrance parser's ranges).
//!
//! The named IORs are those of Mitsuba 3's documentation (the `dielectric` plugin's table).

/// `(name, η, κ)`, RGB.
pub(super) const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "a-C",
        [2.94410, 2.22715, 1.96817],
        [0.887433, 0.799322, 0.815286],
    ),
    (
        "Ag",
        [0.155265, 0.116723, 0.138381],
        [4.82834, 3.12225, 2.14695],
    ),
    (
        "Al",
        [1.65746, 0.880369, 0.521229],
        [9.22387, 6.26952, 4.83700],
    ),
    (
        "Au",
        [0.143119, 0.374957, 1.44248],
        [3.98316, 2.38572, 1.60322],
    ),
    (
        "Be",
        [4.18506, 3.18506, 2.78409],
        [3.83544, 3.01013, 2.86901],
    ),
    (
        "Cr",
        [4.36968, 2.91670, 1.65470],
        [5.20643, 4.23136, 3.75495],
    ),
    (
        "Cu",
        [0.200438, 0.924033, 1.10221],
        [3.91295, 2.45285, 2.14219],
    ),
    (
        "Hg",
        [2.39893, 1.44003, 0.909551],
        [6.32763, 4.37194, 3.42179],
    ),
    (
        "Ir",
        [3.08641, 2.08219, 1.61789],
        [5.59215, 4.06718, 3.26726],
    ),
    (
        "K",
        [0.0640493, 0.0464101, 0.0381842],
        [2.10422, 1.34894, 0.913211],
    ),
    (
        "Li",
        [0.265787, 0.195610, 0.220920],
        [3.54017, 2.31113, 1.66859],
    ),
    (
        "Mo",
        [4.48370, 3.52546, 2.77608],
        [4.11113, 3.42087, 3.15060],
    ),
    (
        "Na_palik",
        [0.0602665, 0.0561412, 0.0619909],
        [3.17929, 2.11248, 1.57909],
    ),
    (
        "Nb",
        [3.42014, 2.79019, 2.39559],
        [3.44138, 2.73764, 2.57991],
    ),
    (
        "Ni_palik",
        [2.36728, 1.66336, 1.46706],
        [4.49883, 3.05016, 2.34543],
    ),
    (
        "Rh",
        [2.58580, 1.86019, 1.55443],
        [6.78229, 4.70295, 3.97609],
    ),
    (
        "Ta",
        [2.06258, 2.39309, 2.62807],
        [2.40805, 1.74137, 1.94704],
    ),
    (
        "TiC",
        [3.70047, 2.83744, 2.58230],
        [3.26569, 2.35156, 2.17279],
    ),
    (
        "TiN",
        [1.64847, 1.15045, 1.37978],
        [3.36846, 1.94349, 1.10201],
    ),
    (
        "V_palik",
        [4.27751, 3.51315, 2.76113],
        [3.49118, 2.88936, 3.11170],
    ),
    (
        "VC",
        [3.65757, 2.75273, 2.53268],
        [3.06835, 2.19867, 1.96318],
    ),
    (
        "VN",
        [2.86560, 2.11918, 1.94008],
        [3.03233, 2.05611, 1.61629],
    ),
    (
        "W",
        [4.37070, 3.30030, 2.99827],
        [3.50068, 2.60487, 2.27319],
    ),
];

/// `(name, index)`.
pub(super) const IORS: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

pub(super) fn metal(name: &str) -> Option<([f32; 3], [f32; 3])> {
    METALS.iter().find(|m| m.0 == name).map(|m| (m.1, m.2))
}

pub(super) fn ior(name: &str) -> Option<f64> {
    IORS.iter().find(|m| m.0 == name).map(|m| m.1)
}

pub(super) fn metal_names() -> String {
    METALS.iter().map(|m| m.0).collect::<Vec<_>>().join(", ")
}
