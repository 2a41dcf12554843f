use truss_deploy::model::parse;

const VALID: &str = r#"[model]
name = "one_unit"
description = "1-unit scissor for error tests"

[settings]
dt_s = 0.05
end_time_s = 10.0

[[joint]]
name = "L0"
position_m = [0.0, 0.0, 0.0]
mass_kg = 0.11

[[joint]]
name = "R0"
position_m = [0.4, 0.0, 0.0]
mass_kg = 0.12

[[joint]]
name = "L1"
position_m = [0.0, 0.0, 0.3]
mass_kg = 0.13

[[joint]]
name = "R1"
position_m = [0.4, 0.0, 0.3]
mass_kg = 0.14

[[element]]
type = "support"
name = "fix_L0"
joints = ["L0"]
fix = "xyz"

[[element]]
type = "support"
name = "slide_R0"
joints = ["R0"]
fix = "yz"

[[element]]
type = "support"
name = "plane_L1"
joints = ["L1"]
fix = "y"

[[element]]
type = "support"
name = "plane_R1"
joints = ["R1"]
fix = "y"

[[element]]
type = "scissor"
name = "U1"
joints = ["L0", "R1", "R0", "L1"]
ratio = 1.0

[[element]]
type = "sleeve"
name = "S1"
joints = ["L0", "L1"]
lock_length_m = 0.45

[[cable]]
name = "drive"
path = ["L0", "R0", "L1", "R1"]
tension_n = 0.5
max_tension_n = 2.0
friction_mu = 0.005
"#;

fn mutate(edits: &[(&str, &str)]) -> String {
    let mut t = VALID.to_string();
    for (old, new) in edits {
        assert_eq!(t.matches(old).count(), 1, "`{old}` must occur once");
        t = t.replacen(old, new, 1);
    }
    t
}

#[test]
fn dump() {
    let cases: Vec<(&str, Vec<(&str, &str)>)> = vec![
        (
            "syntax",
            vec![(
                "position_m = [0.4, 0.0, 0.0]",
                "position_m = [0.4, 0.0, 0.0",
            )],
        ),
        (
            "toplevel",
            vec![(
                "friction_mu = 0.005\n",
                "friction_mu = 0.005\n\n[extras]\ncolour = 1\n",
            )],
        ),
        ("toplevel2", vec![("[model]\n", "colour = 1\n[model]\n")]),
        ("missing mass", vec![("mass_kg = 0.12\n", "")]),
        (
            "unknown joint field",
            vec![("mass_kg = 0.12\n", "mass_kg = 0.12\ncolour = \"red\"\n")],
        ),
        ("dup joint", vec![("name = \"R1\"", "name = \"R0\"")]),
        ("empty joint", vec![("name = \"L1\"", "name = \"\"")]),
        (
            "elem unknown joint",
            vec![(
                "joints = [\"L0\", \"R1\", \"R0\", \"L1\"]",
                "joints = [\"L0\", \"R9\", \"R0\", \"L1\"]",
            )],
        ),
        (
            "cable unknown",
            vec![(
                "path = [\"L0\", \"R0\", \"L1\", \"R1\"]",
                "path = [\"L0\", \"R0\", \"X1\", \"R1\"]",
            )],
        ),
        (
            "nan",
            vec![(
                "position_m = [0.0, 0.0, 0.3]",
                "position_m = [nan, 0.0, 0.3]",
            )],
        ),
        ("inf", vec![("mass_kg = 0.13", "mass_kg = inf")]),
        ("neg", vec![("mass_kg = 0.13", "mass_kg = -0.13")]),
        (
            "path1",
            vec![("path = [\"L0\", \"R0\", \"L1\", \"R1\"]", "path = [\"L0\"]")],
        ),
        (
            "unknown type",
            vec![("type = \"sleeve\"", "type = \"rope\"")],
        ),
        (
            "lenght",
            vec![(
                "lock_length_m = 0.45",
                "lock_length_m = 0.45\nlenght_m = 0.4",
            )],
        ),
        ("no lock", vec![("lock_length_m = 0.45\n", "")]),
        ("fix w", vec![("fix = \"yz\"", "fix = \"w\"")]),
        (
            "pivot",
            vec![(
                "position_m = [0.4, 0.0, 0.3]",
                "position_m = [0.4, 0.0, 0.35]",
            )],
        ),
        ("dup elem", vec![("name = \"S1\"", "name = \"U1\"")]),
        (
            "ref some",
            vec![(
                "mass_kg = 0.12\n",
                "mass_kg = 0.12\nreference_m = [0.2, 0.0, 0.0]\n",
            )],
        ),
        ("tension", vec![("tension_n = 0.5", "tension_n = 5.0")]),
        ("ratio0", vec![("ratio = 1.0", "ratio = 0.0")]),
        ("ratio-", vec![("ratio = 1.0", "ratio = -1")]),
        ("settings nan", vec![("dt_s = 0.05", "dt_s = nan")]),
        ("dt neg", vec![("dt_s = 0.05", "dt_s = -0.05")]),
        (
            "twice",
            vec![("joints = [\"L0\", \"L1\"]", "joints = [\"L0\", \"L0\"]")],
        ),
        (
            "3 joints scissor",
            vec![(
                "joints = [\"L0\", \"R1\", \"R0\", \"L1\"]",
                "joints = [\"L0\", \"R1\", \"R0\"]",
            )],
        ),
        (
            "neg friction",
            vec![("friction_mu = 0.005", "friction_mu = -0.1")],
        ),
        (
            "zero seg",
            vec![(
                "path = [\"L0\", \"R0\", \"L1\", \"R1\"]",
                "path = [\"L0\", \"R0\", \"R0\", \"R1\"]",
            )],
        ),
        (
            "no model",
            vec![(
                "[model]\nname = \"one_unit\"\ndescription = \"1-unit scissor for error tests\"\n",
                "",
            )],
        ),
        (
            "joints str",
            vec![("joints = [\"L0\", \"L1\"]", "joints = \"L0\"")],
        ),
        ("param array", vec![("ratio = 1.0", "ratio = [1.0]")]),
        ("ratio str", vec![("ratio = 1.0", "ratio = \"one\"")]),
        ("ratio nan", vec![("ratio = 1.0", "ratio = nan")]),
        ("ratio huge", vec![("ratio = 1.0", "ratio = 1e308")]),
        (
            "lock latched",
            vec![("lock_length_m = 0.45", "lock_length_m = 0.3")],
        ),
        (
            "lock latched wrong",
            vec![("lock_length_m = 0.45", "lock_length_m = 0.3000001")],
        ),
        ("no elements", vec![]),
    ];
    for (n, e) in cases {
        let t = mutate(&e);
        match parse(&t, "bad.toml") {
            Ok(_) => println!("{n}: OK"),
            Err(e) => println!("{n}: line {:?}: {}", e.line, e.message),
        }
    }
    for t in ["", "[model]\nname = \"x\"\n", "[model]\nname = \"x\"\n[[joint]]\nname = \"a\"\nposition_m = [0.0,0.0,0.0]\nmass_kg = 1.0\n"] {
        match parse(t, "bad.toml") {
            Ok(_) => println!("{t:?}: OK"),
            Err(e) => println!("{t:?}: line {:?}: {}", e.line, e.message),
        }
    }
}
