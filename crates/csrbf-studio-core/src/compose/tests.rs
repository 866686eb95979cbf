//! The scene document's edits, undo and paths.

use super::*;
use csrbf_anim::OrientationKeyFile;

fn doc() -> SceneDoc {
    let file = SceneFile::parse(
        r#"{"duration": 4, "fps": 25,
            "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
            "objects": [{"name": "head", "mesh": "head.off",
              "parts": [{"name": "all", "select": "all",
                "deformations": [{"controls": "smile.json", "phase": [{"time": 0, "phase": 0}]}]}]}]}"#,
    )
    .expect("a scene");
    SceneDoc::new(file, None)
}

#[test]
fn keys_go_in_at_the_playhead_in_time_order_and_undo_restores() {
    let mut d = doc();
    let mut h = SceneHistory::default();
    let start = d.file.clone();
    for (t, x) in [(2.0, 1.0), (0.0, 0.0), (1.0, 0.5)] {
        d.playhead = t;
        h.apply(
            &mut d,
            &SceneEdit::AddKey {
                object: 0,
                track: Track::Position,
                value: KeyValue::Position([x, 0.0, 0.0]),
            },
        )
        .expect("add");
    }
    assert_eq!(d.key_times(0, Track::Position), vec![0.0, 1.0, 2.0]);
    // A key added where one is replaces its value, keeping its TCB.
    h.apply(
        &mut d,
        &SceneEdit::SetTcb {
            object: 0,
            index: 1,
            tcb: [0.5, -0.2, 0.1],
        },
    )
    .expect("tcb");
    d.playhead = 1.0;
    h.apply(
        &mut d,
        &SceneEdit::AddKey {
            object: 0,
            track: Track::Position,
            value: KeyValue::Position([0.7, 0.0, 0.0]),
        },
    )
    .expect("replace");
    let k = d.file.objects[0].trajectory[1];
    assert_eq!((k.position[0], k.tension, k.bias), (0.7, 0.5, 0.1));
    // Moving a key past another reorders; onto another is refused.
    h.apply(
        &mut d,
        &SceneEdit::MoveKey {
            object: 0,
            track: Track::Position,
            index: 0,
            time: 1.5,
        },
    )
    .expect("move");
    assert_eq!(d.key_times(0, Track::Position), vec![1.0, 1.5, 2.0]);
    let before = d.clone();
    for bad in [
        SceneEdit::MoveKey {
            object: 0,
            track: Track::Position,
            index: 0,
            time: 2.0,
        },
        SceneEdit::MoveKey {
            object: 0,
            track: Track::Position,
            index: 0,
            time: 9.0,
        },
        SceneEdit::SetTcb {
            object: 0,
            index: 0,
            tcb: [2.0, 0.0, 0.0],
        },
        SceneEdit::SetTiming {
            fps: 25.0,
            duration: 1.0,
        },
        SceneEdit::RenameObject(0, String::new()),
        // More frames than movies and exports take (the CLI's limit).
        SceneEdit::SetTiming {
            fps: 1000.0,
            duration: 1.0e6,
        },
        SceneEdit::DeleteKey {
            object: 3,
            track: Track::Position,
            index: 0,
        },
    ] {
        assert!(h.apply(&mut d, &bad).is_err(), "{bad:?}");
        assert_eq!(d, before, "{bad:?} changed the scene");
    }
    // Phase keys on a part's deformation.
    d.playhead = 3.0;
    h.apply(
        &mut d,
        &SceneEdit::AddKey {
            object: 0,
            track: Track::Phase {
                part: 0,
                deformation: 0,
            },
            value: KeyValue::Phase(1.0),
        },
    )
    .expect("phase");
    assert_eq!(
        d.key_times(
            0,
            Track::Phase {
                part: 0,
                deformation: 0
            }
        ),
        vec![0.0, 3.0]
    );
    while h.undo(&mut d).is_ok() {}
    assert_eq!(d.file, start);
    h.redo(&mut d).expect("redo");
    assert_eq!(d.key_times(0, Track::Position), vec![2.0]);
}

#[test]
fn keys_are_set_copied_and_objects_replaced_in_one_step_each() {
    let mut d = doc();
    let mut h = SceneHistory::default();
    for t in [0.0, 2.0] {
        d.playhead = t;
        h.apply(
            &mut d,
            &SceneEdit::AddKey {
                object: 0,
                track: Track::Position,
                value: KeyValue::Position([t, 0.0, 0.0]),
            },
        )
        .expect("add");
    }
    h.apply(
        &mut d,
        &SceneEdit::SetTcb {
            object: 0,
            index: 1,
            tcb: [0.3, 0.0, -0.4],
        },
    )
    .expect("tcb");
    // Setting a key's value keeps its time and TCB.
    h.apply(
        &mut d,
        &SceneEdit::SetKey {
            object: 0,
            track: Track::Position,
            index: 1,
            value: KeyValue::Position([5.0, 1.0, 0.0]),
        },
    )
    .expect("set");
    let k = d.file.objects[0].trajectory[1];
    assert_eq!((k.time, k.position, k.tension), (2.0, [5.0, 1.0, 0.0], 0.3));
    // A copy lands at the playhead with value and TCB.
    d.playhead = 3.0;
    h.apply(
        &mut d,
        &SceneEdit::CopyKey {
            object: 0,
            track: Track::Position,
            index: 1,
        },
    )
    .expect("copy");
    let c = d.file.objects[0].trajectory[2];
    assert_eq!((c.time, c.position, c.bias), (3.0, [5.0, 1.0, 0.0], -0.4));
    // An orientation written as axis and angle reads as its quaternion.
    let q = orientation_quaternion(&OrientationKeyFile {
        time: 0.0,
        quaternion: None,
        axis: Some([0.0, 0.0, 1.0]),
        angle: Some(90.0),
        euler: None,
    })
    .expect("rotation");
    assert!((q[2] - 0.5f64.sqrt()).abs() < 1e-12 && (q[3] - 0.5f64.sqrt()).abs() < 1e-12);
    // The panel's edits replace the object whole; names stay unique.
    let mut o = d.file.objects[0].clone();
    o.scale = 2.0;
    h.apply(&mut d, &SceneEdit::ReplaceObject(0, Box::new(o)))
        .expect("replace");
    assert_eq!(d.file.objects[0].scale, 2.0);
    // The last object can go (a scene being built), but is not saveable.
    h.apply(&mut d, &SceneEdit::RemoveObject(0))
        .expect("remove");
    assert!(d.saveable().is_err());
    h.undo(&mut d).expect("undo");
    assert!(d.saveable().is_ok());
}

#[test]
fn a_saved_scene_reads_back_equal_and_the_cli_accepts_its_text() {
    let mut d = doc();
    let mut h = SceneHistory::default();
    d.playhead = 1.0;
    h.apply(
        &mut d,
        &SceneEdit::AddKey {
            object: 0,
            track: Track::Orientation,
            value: KeyValue::Orientation([0.0, 0.0, 2.0, 2.0]),
        },
    )
    .expect("orientation");
    let mut other = d.file.objects[0].clone();
    other.name = "ball".into();
    h.apply(&mut d, &SceneEdit::AddObject(Box::new(other.clone())))
        .expect("add");
    assert!(
        h.apply(&mut d, &SceneEdit::AddObject(Box::new(other)))
            .is_err(),
        "names stay unique"
    );
    h.apply(
        &mut d,
        &SceneEdit::SetTiming {
            fps: 30.0,
            duration: 2.0,
        },
    )
    .expect("timing");
    let light = LightFile {
        direction: [0.0, -1.0, -0.5],
        color: [1.0, 0.9, 0.8],
        intensity: 0.7,
    };
    h.apply(&mut d, &SceneEdit::SetLights(vec![light.clone()]))
        .expect("lights");
    for bad in [
        LightFile {
            direction: [0.0; 3],
            ..light.clone()
        },
        LightFile {
            color: [1.0, -0.1, 0.0],
            ..light.clone()
        },
        LightFile {
            intensity: f32::NAN,
            ..light.clone()
        },
    ] {
        let e = h
            .apply(&mut d, &SceneEdit::SetLights(vec![light.clone(), bad]))
            .expect_err("refused");
        assert!(e.to_string().contains("light 1"), "{e}");
    }
    assert_eq!(d.file.lights, vec![light], "a refused edit changes nothing");
    let back = SceneFile::parse(&d.to_text()).expect("the CLI's parser reads it");
    assert_eq!(back, d.file);
    let q = back.objects[0].orientation[0]
        .quaternion
        .expect("quaternion");
    assert!((q[2] - 0.5f64.sqrt()).abs() < 1e-12, "normalised: {q:?}");
}

#[test]
fn undoing_back_to_the_saved_scene_is_saved_again() {
    let mut d = doc();
    let mut h = SceneHistory::default();
    h.mark_saved(&mut d);
    let timing = |fps: f64| SceneEdit::SetTiming { fps, duration: 4.0 };
    h.apply(&mut d, &timing(30.0)).expect("edit");
    assert!(d.dirty);
    h.undo(&mut d).expect("undo");
    assert!(!d.dirty, "back at the saved scene");
    h.redo(&mut d).expect("redo");
    assert!(d.dirty);
    // A slider's merged steps that end where they began are saved too.
    h.undo(&mut d).expect("undo");
    h.apply_merging(&mut d, &timing(26.0), "timing")
        .expect("edit");
    h.apply_merging(&mut d, &timing(25.0), "timing")
        .expect("edit");
    assert!(!d.dirty);
}
