//! Array-name conventions of multi-material data, shared by the ParaView filter (through the bridge) and
//! the CLI so that both read the same names the same way:
//! - a material's name from its volume-fraction array's name ([`material_name`]);
//! - per-material field arrays matched to (field, material) by name ([`match_material_fields`]):
//!   `"<field> for <material>"` (CTH writes "Mass for Armor Plate") or `"<field> (<material>)"` (what
//!   the filter writes for its per-material outputs, e.g. "Density (Void)");
//! - the fields those arrays define ([`material_fields`]): a per-material array whose field is not
//!   among the given ones defines that field ("Mass for Armor Plate" alone gives a field "Mass");
//! - the mixed field of a field given only per material ([`mixed_from_materials`]).

/// A material's name from its volume-fraction array's name: "Volume Fraction for Armor Plate" →
/// "Armor Plate", "Void Volume Fraction" → "Void", "steel_fraction" → "steel"; the array name itself when
/// nothing would be left.
pub fn material_name(array: &str) -> String {
    let lower = array.to_ascii_lowercase();
    for prefix in [
        "volume fraction for ",
        "volume fraction of ",
        "volumefraction_",
        "volume fraction ",
    ] {
        if lower.starts_with(prefix) && lower.len() > prefix.len() {
            return array[prefix.len()..].to_string();
        }
    }
    for suffix in [
        " volume fraction",
        "_volume_fraction",
        "_volumefraction",
        " fraction",
        "_fraction",
    ] {
        if lower.ends_with(suffix) && lower.len() > suffix.len() && lower != "volume fraction" {
            return array[..array.len() - suffix.len()].to_string();
        }
    }
    array.to_string()
}

/// Distinct, non-empty material names of the fraction arrays (the array names themselves when two
/// names clash or one is empty).
pub fn material_names<S: AsRef<str>>(arrays: &[S]) -> Vec<String> {
    let names: Vec<String> = arrays.iter().map(|a| material_name(a.as_ref())).collect();
    let clash = names
        .iter()
        .enumerate()
        .any(|(i, n)| n.is_empty() || names[i + 1..].contains(n));
    if clash {
        arrays.iter().map(|a| a.as_ref().to_string()).collect()
    } else {
        names
    }
}

/// The (field, material) of each per-material array: `arrays[i]` must be named
/// `"<fields[f]> for <materials[m]>"` or `"<fields[f]> (<materials[m]>)"` (exactly, case included). An
/// error names the first array that matches nothing (listing the accepted names), an array that matches
/// two (field, material) pairs, and two arrays for the same pair.
pub fn match_material_fields<F: AsRef<str>, M: AsRef<str>, A: AsRef<str>>(
    fields: &[F],
    materials: &[M],
    arrays: &[A],
) -> Result<Vec<(usize, usize)>, String> {
    let candidates = |f: &str, m: &str| [format!("{f} for {m}"), format!("{f} ({m})")];
    let mut out: Vec<(usize, usize)> = Vec::with_capacity(arrays.len());
    for array in arrays.iter().map(AsRef::as_ref) {
        let mut found = Vec::new();
        for (f, field) in fields.iter().map(AsRef::as_ref).enumerate() {
            for (m, material) in materials.iter().map(AsRef::as_ref).enumerate() {
                if candidates(field, material).iter().any(|c| c == array) {
                    found.push((f, m));
                }
            }
        }
        match found[..] {
            [] => {
                let quoted = |list: &mut dyn Iterator<Item = String>| {
                    list.map(|s| format!("\"{s}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                let accepted = quoted(&mut fields.iter().flat_map(|f| {
                    materials
                        .iter()
                        .flat_map(move |m| candidates(f.as_ref(), m.as_ref()))
                }));
                return Err(format!(
                    "the per-material field array \"{array}\" matches no field and material: name it \"<field> for <material>\" or \"<field> (<material>)\" with a field of [{}] and a material of [{}]; accepted names: {}",
                    quoted(&mut fields.iter().map(|f| f.as_ref().to_string())),
                    quoted(&mut materials.iter().map(|m| m.as_ref().to_string())),
                    if accepted.is_empty() { "none (no field is selected)".to_string() } else { accepted }
                ));
            }
            [pair] => {
                if let Some(j) = out.iter().position(|&p| p == pair) {
                    return Err(format!(
                        "the per-material field arrays \"{}\" and \"{array}\" both give field \"{}\" of material \"{}\"; select one",
                        arrays[j].as_ref(),
                        fields[pair.0].as_ref(),
                        materials[pair.1].as_ref()
                    ));
                }
                out.push(pair);
            }
            _ => {
                let pairs: Vec<String> = found
                    .iter()
                    .map(|&(f, m)| {
                        format!(
                            "field \"{}\" of material \"{}\"",
                            fields[f].as_ref(),
                            materials[m].as_ref()
                        )
                    })
                    .collect();
                return Err(format!(
                    "the per-material field array \"{array}\" is ambiguous: it names {}",
                    pairs.join(" and ")
                ));
            }
        }
    }
    Ok(out)
}

/// The result of [`material_fields`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MaterialFieldMatch {
    /// The given fields, then those defined only by per-material arrays, in order of first appearance.
    pub fields: Vec<String>,
    /// The (field into `fields`, material) of each per-material array.
    pub pairs: Vec<(usize, usize)>,
}

/// The fields of the per-material arrays and the (field, material) of each array: the given `fields`
/// first, then, in order of first appearance, the fields defined only by the arrays. An array that
/// matches no given field but is named `"<field> for <material>"` or `"<field> (<material>)"` with a
/// non-empty `<field>` and `<material>` one of `materials` defines `<field>` (a field given only per
/// material: CTH's "Mass for Armor Plate" and "Mass for Body, Nose" give a field "Mass" without a
/// "Mass" array). The arrays are then matched to the full list by [`match_material_fields`], with its
/// errors (an array whose material is none of `materials`, an ambiguous array, two arrays for one
/// pair).
pub fn material_fields<F: AsRef<str>, M: AsRef<str>, A: AsRef<str>>(
    fields: &[F],
    materials: &[M],
    arrays: &[A],
) -> Result<MaterialFieldMatch, String> {
    let mut all: Vec<String> = fields.iter().map(|f| f.as_ref().to_string()).collect();
    for array in arrays.iter().map(AsRef::as_ref) {
        let given = fields.iter().any(|f| {
            materials.iter().any(|m| {
                let (f, m) = (f.as_ref(), m.as_ref());
                array == format!("{f} for {m}") || array == format!("{f} ({m})")
            })
        });
        if given {
            continue;
        }
        for m in materials.iter().map(AsRef::as_ref) {
            let prefixes = [
                array.strip_suffix(&format!(" for {m}")),
                array.strip_suffix(&format!(" ({m})")),
            ];
            for field in prefixes.into_iter().flatten() {
                if !field.is_empty() && !all.iter().any(|f| f == field) {
                    all.push(field.to_string());
                }
            }
        }
    }
    let pairs = match_material_fields(&all, materials, arrays)?;
    Ok(MaterialFieldMatch { fields: all, pairs })
}

/// The mixed field of a field given only per material: `Σ fraction × per-material value` at every
/// point, over the materials given in `per_material` as (material index into `fractions`, values); the
/// materials without an array count 0. The value of a material is read only where its fraction is not
/// 0, so it may be anything (even NaN) elsewhere. Every array has one value per point of `fractions[0]`
/// (the caller checks the lengths).
pub fn mixed_from_materials(fractions: &[&[f32]], per_material: &[(usize, &[f32])]) -> Vec<f32> {
    let n = fractions.first().map_or(0, |f| f.len());
    (0..n)
        .map(|p| {
            per_material
                .iter()
                .map(|&(m, values)| {
                    let w = fractions[m][p] as f64;
                    if w == 0.0 {
                        0.0
                    } else {
                        w * values[p] as f64
                    }
                })
                .sum::<f64>() as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_names_from_array_names() {
        assert_eq!(
            material_name("Volume Fraction for Armor Plate"),
            "Armor Plate"
        );
        assert_eq!(material_name("Void Volume Fraction"), "Void");
        assert_eq!(
            material_name("volume fraction for Body, Nose"),
            "Body, Nose"
        );
        assert_eq!(material_name("steel_fraction"), "steel");
        assert_eq!(material_name("Volume Fraction"), "Volume Fraction");
        assert_eq!(material_name("vf"), "vf");
        let arrays = ["A Volume Fraction", "Volume Fraction for A"];
        assert_eq!(material_names(&arrays), arrays.to_vec());
    }

    #[test]
    fn material_field_arrays_match_by_name() {
        let fields = ["Mass", "Density"];
        let materials = ["Void", "Armor Plate", "Body, Nose"];
        let arrays = [
            "Mass for Armor Plate",
            "Mass for Body, Nose",
            "Density (Void)",
            "Density for Body, Nose",
        ];
        assert_eq!(
            match_material_fields(&fields, &materials, &arrays).unwrap(),
            [(0, 1), (0, 2), (1, 0), (1, 2)]
        );
        let e = match_material_fields(&fields, &materials, &["Mass for Steel"]).unwrap_err();
        assert!(e.contains("\"Mass for Steel\"") && e.contains("\"Mass for Armor Plate\""));
        assert!(e.contains("\"Density (Body, Nose)\""), "{e}");
        let e = match_material_fields(&fields, &materials, &["mass for Void"]).unwrap_err();
        assert!(e.contains("matches no field"), "{e}");
        let e = match_material_fields(&fields, &materials, &["Mass for Void", "Mass (Void)"])
            .unwrap_err();
        assert!(e.contains("both give"), "{e}");
        let e = match_material_fields(&["A for B", "A"], &["C", "B for C"], &["A for B for C"])
            .unwrap_err();
        assert!(e.contains("ambiguous"), "{e}");
        let none: [&str; 0] = [];
        let e = match_material_fields(&none, &materials, &["Mass for Void"]).unwrap_err();
        assert!(e.contains("no field is selected"), "{e}");
        assert!(match_material_fields(&none, &materials, &none)
            .unwrap()
            .is_empty());
    }

    #[test]
    fn per_material_arrays_define_missing_fields() {
        let materials = ["Void", "Armor Plate", "Body, Nose"];
        // CTH: no "Mass" array, no field given: the arrays define "Mass".
        let MaterialFieldMatch { fields, pairs } = material_fields(
            &[] as &[&str],
            &materials,
            &["Mass for Armor Plate", "Mass for Body, Nose"],
        )
        .unwrap();
        assert_eq!(fields, ["Mass"]);
        assert_eq!(pairs, [(0, 1), (0, 2)]);
        // Given fields first (not duplicated), then the inferred ones in order of first appearance.
        let arrays = [
            "Pressure (Void)",
            "Density for Armor Plate",
            "Mass for Body, Nose",
            "Pressure for Body, Nose",
            "Mass (Void)",
        ];
        let MaterialFieldMatch { fields, pairs } =
            material_fields(&["Density"], &materials, &arrays).unwrap();
        assert_eq!(fields, ["Density", "Pressure", "Mass"]);
        assert_eq!(pairs, [(1, 0), (0, 1), (2, 2), (1, 2), (2, 0)]);
        let MaterialFieldMatch { fields, pairs } =
            material_fields(&["Mass", "Density"], &materials, &arrays).unwrap();
        assert_eq!(fields, ["Mass", "Density", "Pressure"]);
        assert_eq!(pairs, [(2, 0), (1, 1), (0, 2), (2, 2), (0, 0)]);
        // Nothing to infer: the given fields alone.
        let MaterialFieldMatch { fields, pairs } =
            material_fields(&["Mass"], &materials, &[] as &[&str]).unwrap();
        assert_eq!(fields, ["Mass"]);
        assert!(pairs.is_empty());
        // A material that is none of the materials defines nothing: still an error.
        let e = material_fields(&["Mass"], &materials, &["Mass for Steel"]).unwrap_err();
        assert!(
            e.contains("matches no field") && e.contains("\"Mass for Steel\""),
            "{e}"
        );
        let e = material_fields(&[] as &[&str], &materials, &["Density for Steel"]).unwrap_err();
        assert!(e.contains("matches no field"), "{e}");
        let e = material_fields(&[] as &[&str], &materials, &[" for Void"]).unwrap_err();
        assert!(e.contains("matches no field"), "{e}");
        // Ambiguity and duplicates: the rules of `match_material_fields`.
        let e = material_fields(&[] as &[&str], &["C", "B for C"], &["A for B for C"]).unwrap_err();
        assert!(e.contains("ambiguous"), "{e}");
        let e = material_fields(
            &[] as &[&str],
            &materials,
            &["Mass for Void", "Mass (Void)"],
        )
        .unwrap_err();
        assert!(e.contains("both give"), "{e}");
    }

    #[test]
    fn mixed_from_materials_weights_by_fraction() {
        let f0 = [1.0, 0.5, 0.0];
        let f1 = [0.0, 0.5, 1.0];
        let v1 = [f32::NAN, 4.0, 6.0];
        // Material 0 has no array: it counts 0; material 1's NaN is where its fraction is 0.
        assert_eq!(
            mixed_from_materials(&[&f0, &f1], &[(1, &v1)]),
            [0.0, 2.0, 6.0]
        );
        let v0 = [2.0, 2.0, 9.0];
        assert_eq!(
            mixed_from_materials(&[&f0, &f1], &[(0, &v0), (1, &v1)]),
            [2.0, 3.0, 6.0]
        );
    }
}
