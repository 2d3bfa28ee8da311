//! Which input arrays a material approximation reads, shared by the ParaView filter (through the
//! bridge) and the CLI so that both select the same arrays the same way:
//! - the volume-fraction arrays: the selected ones, else every single-component array named like a
//!   fraction (point data first, then cell data);
//! - the selections name different arrays;
//! - the material names ([`material_names`]) and the fields with the (field, material) of each
//!   per-material array ([`material_fields`]);
//! - the input array each field is read from, if any: a field defined only by per-material arrays,
//!   or a selected field that is no input array but is given per material, is computed from the
//!   per-material arrays;
//! - every array to read exists and has one component.

use super::naming::{material_fields, material_names, MaterialFieldMatch};

/// A numeric array of the input, as the caller lists them: point data first, then cell data.
#[derive(Clone, Copy, Debug)]
pub struct InputArray<'a> {
    pub name: &'a str,
    pub components: usize,
    /// Cell data (converted to point data before use), else point data.
    pub cell: bool,
}

/// The names of the options that select the arrays, for messages (the filter's properties, the
/// CLI's flags).
#[derive(Clone, Copy, Debug)]
pub struct SelectionOptions<'a> {
    pub fractions: &'a str,
    pub fields: &'a str,
    pub material_fields: &'a str,
}

/// An input array to read, by name; cell data is converted to point data first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SelectedArray {
    pub name: String,
    pub cell: bool,
}

/// A field to approximate: its name, and the input array holding its mixed values (`None`: computed
/// from its per-material arrays as `Σ fraction × value`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SelectedField {
    pub name: String,
    pub array: Option<SelectedArray>,
}

/// A per-material field array: the values of field `field` inside material `material`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SelectedMaterialField {
    pub array: SelectedArray,
    pub field: usize,
    pub material: usize,
}

/// What [`select_arrays`] chose.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ArraySelection {
    /// One name per material, from its fraction array's name.
    pub materials: Vec<String>,
    /// One array per material.
    pub fractions: Vec<SelectedArray>,
    /// The selected fields, then those defined only by per-material arrays.
    pub fields: Vec<SelectedField>,
    pub material_fields: Vec<SelectedMaterialField>,
}

impl ArraySelection {
    /// The field names, in order.
    pub fn field_names(&self) -> Vec<String> {
        self.fields.iter().map(|f| f.name.clone()).collect()
    }
}

/// Chooses the arrays to read from `input` for the selected `fractions` (empty: every
/// single-component array whose name contains "fraction", case ignored), `fields` and
/// `material_fields` (empty names are ignored). Errors name the option (`options`) and list the
/// input's arrays where that helps: fewer than 2 fractions found, an array selected twice, a
/// per-material array matching no field and material, an array to read that is missing or has
/// more than one component.
pub fn select_arrays<S: AsRef<str>>(
    input: &[InputArray<'_>],
    fractions: &[S],
    fields: &[S],
    material_field_arrays: &[S],
    options: &SelectionOptions<'_>,
) -> Result<ArraySelection, String> {
    let names = |list: &[S]| -> Vec<String> {
        list.iter()
            .map(|s| s.as_ref().to_string())
            .filter(|s| !s.is_empty())
            .collect()
    };
    let (mut fractions, fields, material_field_arrays) = (
        names(fractions),
        names(fields),
        names(material_field_arrays),
    );
    if fractions.is_empty() {
        for a in input {
            if a.components == 1
                && a.name.to_ascii_lowercase().contains("fraction")
                && !fractions.iter().any(|f| f == a.name)
            {
                fractions.push(a.name.to_string());
            }
        }
        if fractions.len() < 2 {
            return Err(format!(
                "select the volume-fraction arrays, one per material, at least 2 ({}); none was selected and the input has {} array(s) named like a fraction; {}",
                options.fractions,
                fractions.len(),
                listing(input)
            ));
        }
    }
    let all: Vec<&String> = fractions
        .iter()
        .chain(&fields)
        .chain(&material_field_arrays)
        .collect();
    if let Some((_, twice)) = all
        .iter()
        .enumerate()
        .find(|(i, a)| all[i + 1..].contains(a))
    {
        return Err(format!(
            "array \"{twice}\" is selected twice ({}, {} and {} must name different arrays)",
            options.fractions, options.fields, options.material_fields
        ));
    }
    let materials = material_names(&fractions);
    let MaterialFieldMatch {
        fields: field_names,
        pairs,
    } = material_fields(&fields, &materials, &material_field_arrays)
        .map_err(|e| format!("{}: {e}", options.material_fields))?;

    let find = |name: &str, option: &str| -> Result<SelectedArray, String> {
        let a = input.iter().find(|a| a.name == name).ok_or_else(|| {
            format!(
                "the input has no numeric point or cell array named \"{name}\" ({option}); {}",
                listing(input)
            )
        })?;
        if a.components != 1 {
            return Err(format!(
                "array \"{name}\" ({option}) has {} components; one value per point or cell is needed (extract a component first)",
                a.components
            ));
        }
        Ok(SelectedArray {
            name: name.to_string(),
            cell: a.cell,
        })
    };
    let fractions = fractions
        .iter()
        .map(|n| find(n, options.fractions))
        .collect::<Result<_, _>>()?;
    let in_input = |name: &str| input.iter().any(|a| a.name == name);
    let fields = field_names
        .into_iter()
        .enumerate()
        .map(|(f, name)| {
            let per_material = pairs.iter().any(|&(g, _)| g == f);
            let array = if f >= fields.len() || (!in_input(&name) && per_material) {
                None
            } else {
                Some(find(&name, options.fields)?)
            };
            Ok(SelectedField { name, array })
        })
        .collect::<Result<_, String>>()?;
    let material_fields = material_field_arrays
        .iter()
        .zip(pairs)
        .map(|(name, (field, material))| {
            Ok(SelectedMaterialField {
                array: find(name, options.material_fields)?,
                field,
                material,
            })
        })
        .collect::<Result<_, String>>()?;
    Ok(ArraySelection {
        materials,
        fractions,
        fields,
        material_fields,
    })
}

/// "point arrays: "a", "b"; cell arrays: "c"", for messages.
fn listing(input: &[InputArray<'_>]) -> String {
    let quoted = |cell: bool| {
        input
            .iter()
            .filter(|a| a.cell == cell)
            .map(|a| format!("\"{}\"", a.name))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "point arrays: {}; cell arrays: {}",
        quoted(false),
        quoted(true)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPTIONS: SelectionOptions = SelectionOptions {
        fractions: "F",
        fields: "D",
        material_fields: "M",
    };

    fn point(name: &str) -> InputArray<'_> {
        InputArray {
            name,
            components: 1,
            cell: false,
        }
    }

    fn array(name: &str, cell: bool) -> SelectedArray {
        SelectedArray {
            name: name.to_string(),
            cell,
        }
    }

    const NONE: [&str; 0] = [];

    #[test]
    fn fractions_are_found_by_name_when_none_is_selected() {
        let input = [
            point("Density"),
            point("Volume Fraction for Void"),
            InputArray {
                components: 3,
                ..point("vector fraction")
            },
            InputArray {
                cell: true,
                ..point("steel_FRACTION")
            },
            InputArray {
                cell: true,
                ..point("Volume Fraction for Void")
            },
        ];
        let s = select_arrays(&input, &NONE, &["Density"], &NONE, &OPTIONS).unwrap();
        assert_eq!(
            s.fractions,
            [
                array("Volume Fraction for Void", false),
                array("steel_FRACTION", true)
            ]
        );
        assert_eq!(s.materials, ["Void", "steel"]);
        assert_eq!(
            s.fields,
            [SelectedField {
                name: "Density".into(),
                array: Some(array("Density", false))
            }]
        );
        let e = select_arrays(&input[..3], &NONE, &NONE, &NONE, &OPTIONS).unwrap_err();
        assert!(
            e.contains("at least 2 (F)")
                && e.contains("1 array(s)")
                && e.contains("point arrays: \"Density\""),
            "{e}"
        );
    }

    #[test]
    fn selections_are_checked() {
        let input = [
            point("a fraction"),
            point("b fraction"),
            point("Density"),
            InputArray {
                components: 3,
                ..point("Vec")
            },
            point("Density for a"),
        ];
        let fractions = ["a fraction", "b fraction", ""];
        let twice = select_arrays(&input, &fractions, &["a fraction"], &NONE, &OPTIONS);
        assert!(twice
            .unwrap_err()
            .contains("\"a fraction\" is selected twice (F, D and M"));
        let missing = select_arrays(&input, &fractions, &["Nope"], &NONE, &OPTIONS).unwrap_err();
        assert!(
            missing.contains("no numeric point or cell array named \"Nope\" (D)"),
            "{missing}"
        );
        let vector = select_arrays(&input, &fractions, &["Vec"], &NONE, &OPTIONS).unwrap_err();
        assert!(vector.contains("3 components"), "{vector}");
        let unmatched = select_arrays(&input, &fractions, &NONE, &["Density for c"], &OPTIONS);
        assert!(unmatched.unwrap_err().starts_with("M: "));
    }

    #[test]
    fn fields_given_per_material_are_computed_unless_read() {
        let input = [
            point("a fraction"),
            point("b fraction"),
            point("Density"),
            point("Density for a"),
            point("Mass (b)"),
        ];
        let fractions = ["a fraction", "b fraction"];
        let per_material = ["Density for a", "Mass (b)"];
        // "Density" is read, "Mass" (defined by its array alone) computed.
        let s = select_arrays(&input, &fractions, &["Density"], &per_material, &OPTIONS).unwrap();
        assert_eq!(s.field_names(), ["Density", "Mass"]);
        assert_eq!(s.fields[0].array, Some(array("Density", false)));
        assert_eq!(s.fields[1].array, None);
        assert_eq!(
            s.material_fields,
            [
                SelectedMaterialField {
                    array: array("Density for a", false),
                    field: 0,
                    material: 0
                },
                SelectedMaterialField {
                    array: array("Mass (b)", false),
                    field: 1,
                    material: 1
                }
            ]
        );
        // A selected field that is no input array: computed when given per material, else an error.
        let s = select_arrays(&input, &fractions, &["Mass"], &["Mass (b)"], &OPTIONS).unwrap();
        assert_eq!(s.fields[0].array, None);
        let e = select_arrays(&input, &fractions, &["Mass"], &["Density for a"], &OPTIONS);
        assert!(e.unwrap_err().contains("named \"Mass\""));
    }
}
