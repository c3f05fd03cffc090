//! The edge keeps each object's last forecast and blends the next one with it as the model's
//! prior says (`PriorSettings::carry_percent`): on the 16-car fixture stream, the default model
//! (carry 60 %) and the same model with no carry make the same first forecast of every object,
//! and from the second on the carried forecasts agree better from frame to frame (ACE).

use std::collections::HashMap;

use dynotraj_core::model::blob::ModelBlob;
use dynotraj_core::wire::{Message, Prediction, crc32};
use dynotraj_tests::edge_fixture::{default_model_blob, encode_all, host_messages, reference_replies, scene_tracks};

/// `blob` with its carry set to `percent` (header byte 34) and its CRC made good again.
fn with_carry(blob: &[u8], percent: u8) -> Vec<u8> {
    let mut b = blob.to_vec();
    b[34] = percent;
    let n = b.len() - 4;
    let crc = crc32(&b[..n]);
    b[n..].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(ModelBlob::parse_exact(&b).unwrap().prior().carry_percent, percent);
    b
}

fn predictions(model: &[u8]) -> Vec<Prediction> {
    let tracks = scene_tracks(20);
    reference_replies(&encode_all(&host_messages(&tracks, Some(model))), &[model])
        .into_iter()
        .filter_map(|m| if let Message::Prediction(p) = m { Some(p) } else { None })
        .collect()
}

/// Mean distance between consecutive forecasts of one object at the times both cover (the
/// paper's ACE), over every object, and the number of pairs.
fn ace(forecasts: &[Prediction]) -> (f64, usize) {
    let mut last: HashMap<u16, &Prediction> = HashMap::new();
    let (mut sum, mut pairs) = (0.0, 0);
    for p in forecasts {
        if let Some(q) = last.get(&p.object_id).filter(|q| q.frame + 1 == p.frame) {
            let d: f32 = q.points[1..].iter().zip(&p.points).map(|(a, b)| a.distance(b)).sum();
            sum += f64::from(d) / (q.points.len() - 1) as f64;
            pairs += 1;
        }
        last.insert(p.object_id, p);
    }
    (sum / pairs.max(1) as f64, pairs)
}

#[test]
fn the_edge_carries_each_objects_last_forecast() {
    let default = std::fs::read(default_model_blob()).unwrap();
    assert!(ModelBlob::parse_exact(&default).unwrap().prior().carry_percent > 0, "the default model carries");
    let (carried, fresh) = (predictions(&default), predictions(&with_carry(&default, 0)));
    assert_eq!(carried.len(), fresh.len(), "the same forecasts are made");
    let mut seen = std::collections::HashSet::new();
    let mut changed = 0;
    for (c, f) in carried.iter().zip(&fresh) {
        assert_eq!((c.frame, c.object_id), (f.frame, f.object_id));
        if seen.insert(c.object_id) {
            assert_eq!(c.points, f.points, "an object's first forecast has nothing to carry");
        } else if c.points != f.points {
            changed += 1;
        }
    }
    assert!(changed > carried.len() / 2, "later forecasts are blended: {changed} of {}", carried.len());
    let ((a, pairs), (b, _)) = (ace(&carried), ace(&fresh));
    println!("ACE over {pairs} pairs: carried {a:.4} m, fresh {b:.4} m");
    assert!(pairs > 100 && a < b, "carried {a} against fresh {b}");
}
