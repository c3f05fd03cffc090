//! The renderer against its first version, kept here as the reference: bit for bit on any
//! number of threads and with either optics.

use super::*;
use crate::image_sim::Optics;
use crate::image_sim::scene::GroundPlane;
use crate::image_sim::texture::{hash, intensity};
use nalgebra::Translation3;

/// A box hit: distance along the ray and the local hit point and face axis.
fn hit_box(origin: &Point3<f64>, dir: &Vector3<f64>, half: &Vector3<f64>) -> Option<(f64, Point3<f64>, usize, f64)> {
    let (mut t0, mut t1) = (0.0f64, FAR);
    let mut axis = usize::MAX;
    let mut sign = 1.0;
    for a in 0..3 {
        let (o, d, h) = (origin[a], dir[a], half[a]);
        if d.abs() < 1e-12 {
            if o.abs() > h {
                return None;
            }
            continue;
        }
        let (mut near, mut far) = ((-h - o) / d, (h - o) / d);
        let mut s = -1.0;
        if near > far {
            std::mem::swap(&mut near, &mut far);
            s = 1.0;
        }
        if near > t0 {
            t0 = near;
            axis = a;
            sign = s;
        }
        t1 = t1.min(far);
        if t0 > t1 {
            return None;
        }
    }
    (axis != usize::MAX).then(|| (t0, origin + dir * t0, axis, sign))
}

/// [`place`] as first written: a box partly behind the camera tests every pixel.
fn reference_place<'a>(cam: &Camera, world_to_cam: &Isometry3<f64>, c: &'a Cuboid, id: u16) -> Option<Placed<'a>> {
    let to_cam = world_to_cam * c.pose;
    let (mut rect, behind) = corner_rect(cam, &to_cam, &c.half)?;
    if behind > 0 {
        // Part of the box is behind the camera: its projection is unbounded, test every pixel.
        rect = (0, 0, cam.width - 1, cam.height - 1);
    }
    (rect.0 <= rect.2 && rect.1 <= rect.3).then(|| {
        let to_local = to_cam.inverse();
        Placed { to_local, origin: to_local * Point3::origin(), cuboid: c, id, rect }
    })
}

/// The renderer as first written: ground and sky everywhere, then every box over them.
fn reference(
    cam: &Camera,
    pose: &Isometry3<f64>,
    scene: &StaticScene,
    objects: &[(u16, Cuboid)],
    frame_seed: u32,
) -> View {
    let (w, h) = (cam.width, cam.height);
    let n = w * h;
    let mut depth = vec![f64::INFINITY; n];
    // Radiance in grey levels before the sensor: optics, then noise and quantisation, apply
    // once every surface has been drawn.
    let mut rgb = vec![0f32; 3 * n];
    let mut ids = vec![0u16; n];
    let world_to_cam = pose.inverse();
    let rot = pose.rotation;
    let area = cam.optics.pixel_area;
    let ray = |u: usize, v: usize| Vector3::new((u as f64 - cam.cx) / cam.fx, (v as f64 - cam.cy) / cam.fy, 1.0);
    let put = |rgb: &mut [f32], i: usize, colour: [f32; 3], shade: f32, t: f32| {
        for c in 0..3 {
            rgb[3 * i + c] = 255.0 * colour[c] * shade * (0.25 + 0.75 * t);
        }
    };
    // Sky and ground.
    let footprint = |z: f64| z / cam.fx;
    for v in 0..h {
        for u in 0..w {
            let i = v * w + u;
            let d = ray(u, v);
            let dw = rot * d;
            // The ray o + z dw meets the plane y - bx x - bz z = height where z is the depth.
            let g = &scene.ground;
            let o = pose.translation.vector;
            let down = dw.y - g.slope_x * dw.x - g.slope_z * dw.z;
            let z = if down > 1e-9 { (g.height - (o.y - g.slope_x * o.x - g.slope_z * o.z)) / down } else { -1.0 };
            if z > 0.0 && z < FAR {
                let p = pose.translation.vector + dw * z;
                let t = intensity(scene.ground_texture, p.x, p.z, footprint(z), 1.0, area);
                depth[i] = z;
                put(&mut rgb, i, [0.55, 0.55, 0.52], 0.9, t);
            } else {
                // Sky: flat colour, no texture (a textureless region for the front-end).
                put(&mut rgb, i, [0.55, 0.7, 0.95], 1.0, 1.0);
            }
        }
    }
    // Boxes: static structures (id 0), then objects.
    let placed: Vec<Placed<'_>> = scene
        .structures
        .iter()
        .filter_map(|c| reference_place(cam, &world_to_cam, c, 0))
        .chain(objects.iter().filter_map(|(id, c)| reference_place(cam, &world_to_cam, c, *id)))
        .collect();
    for b in &placed {
        let origin = b.origin;
        for v in b.rect.1..=b.rect.3 {
            for u in b.rect.0..=b.rect.2 {
                let i = v * w + u;
                let dir = b.to_local.rotation * ray(u, v);
                let Some((t, p, axis, sign)) = hit_box(&origin, &dir, &b.cuboid.half) else { continue };
                // The ray's z component is 1 in the camera, so `t` is the depth.
                if t >= depth[i] || t < 0.05 {
                    continue;
                }
                depth[i] = t;
                ids[i] = b.id;
                let (a, c) = match axis {
                    0 => (p.z, p.y),
                    1 => (p.x, p.z),
                    _ => (p.x, p.y),
                };
                let tex = b.cuboid.texture ^ (axis as u32 * 0x51ed_270b) ^ if sign > 0.0 { 0x2545_f491 } else { 0 };
                let t = intensity(tex, a, c, footprint(t), b.cuboid.texture_scale, area);
                put(&mut rgb, i, b.cuboid.colour, face_shade(axis, sign), t);
            }
        }
    }
    let depth = depth.into_iter().map(|z| if z.is_finite() { z as f32 } else { 0.0 }).collect();
    if !cam.optics.is_ideal() {
        reference_optics(&mut rgb, cam, frame_seed);
    }
    let rgb = rgb
        .chunks_exact(3)
        .enumerate()
        .flat_map(|(i, px)| {
            let noise = if cam.noise > 0 {
                (hash(frame_seed ^ hash(i as u32)) % (2 * cam.noise as u32 + 1)) as i32 - cam.noise
            } else {
                0
            };
            px.iter().map(move |x| (*x as i32 + noise).clamp(0, 255) as u8)
        })
        .collect();
    View { rgb, depth, ids }
}

/// One pass of a separable blur of an RGB image of `(w, h)` pixels from `src` into `dst`, along
/// rows (`along_rows`) or columns; the border repeats the edge pixel.
fn reference_blur_pass(src: &[f32], dst: &mut [f32], (w, h): (usize, usize), kernel: &[f32], along_rows: bool) {
    let radius = kernel.len() / 2;
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                dst[3 * (y * w + x) + c] = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, g)| {
                        let (sx, sy) = if along_rows {
                            ((x + k).saturating_sub(radius).min(w - 1), y)
                        } else {
                            (x, (y + k).saturating_sub(radius).min(h - 1))
                        };
                        g * src[3 * (sy * w + sx) + c]
                    })
                    .sum();
            }
        }
    }
}

/// The lens's blur, vignetting and the exposure's gain on a radiance image (RGB, row-major).
fn reference_optics(rgb: &mut [f32], cam: &Camera, frame_seed: u32) {
    let Optics { blur_sigma, vignetting, gain_jitter, .. } = cam.optics;
    let (w, h) = (cam.width, cam.height);
    if blur_sigma > 0.0 {
        let radius = (3.0 * blur_sigma).ceil() as usize;
        let kernel: Vec<f32> = (0..=2 * radius)
            .map(|k| (-((k as f32 - radius as f32).powi(2)) / (2.0 * blur_sigma * blur_sigma)).exp())
            .collect();
        let total: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / total).collect();
        // Separable: rows, then columns; the border repeats the edge pixel.
        let mut tmp = vec![0f32; rgb.len()];
        reference_blur_pass(rgb, &mut tmp, (w, h), &kernel, true);
        reference_blur_pass(&tmp, rgb, (w, h), &kernel, false);
    }
    let gain = 1.0 + gain_jitter * (2.0 * (hash(frame_seed ^ 0x6a09_e667) >> 8) as f32 / (1u32 << 24) as f32 - 1.0);
    let corner2 = ((w * w + h * h) as f32 / 4.0).max(1.0);
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f32 - cam.cx as f32, y as f32 - cam.cy as f32);
            let fall = 1.0 - vignetting * ((dx * dx + dy * dy) / corner2).min(1.0);
            for c in 0..3 {
                rgb[3 * (y * w + x) + c] *= gain * fall;
            }
        }
    }
}

#[test]
fn a_box_ahead_occludes_the_ground_at_its_depth() {
    let cam = Camera {
        fx: 100.0,
        fy: 100.0,
        cx: 50.0,
        cy: 30.0,
        width: 100,
        height: 60,
        baseline_m: 0.5,
        noise: 2,
        optics: Optics::IDEAL,
    };
    let scene = StaticScene { ground: GroundPlane::level(1.65), ground_texture: 1, structures: Vec::new() };
    let b = Cuboid {
        pose: Isometry3::from_parts(Translation3::new(0.0, 0.9, 10.0), nalgebra::UnitQuaternion::identity()),
        half: Vector3::new(1.0, 0.75, 1.0),
        texture: 3,
        colour: [0.8, 0.2, 0.2],
        texture_scale: 1.0,
    };
    let view = render(&cam, &Isometry3::identity(), &scene, &[(7, b)], 0);
    let i = 35 * 100 + 50;
    assert_eq!(view.ids[i], 7);
    assert!((view.depth[i] - 9.0).abs() < 1e-3, "{}", view.depth[i]);
    // Below the box: ground at z = 1.65 * fy / (v - cy).
    let g = 55 * 100 + 5;
    assert_eq!(view.ids[g], 0);
    assert!((f64::from(view.depth[g]) - 1.65 * 100.0 / 25.0).abs() < 1e-3);
    // Above the horizon: sky, no depth.
    assert_eq!(view.depth[5 * 100 + 5], 0.0);
}

/// The boxes of frame `k` of a short synthetic drive, as [`super::super::ImageSim::frame`]
/// makes them.
fn drive_scene(k: usize) -> (Camera, Isometry3<f64>, StaticScene, Vec<(u16, Cuboid)>) {
    use crate::drive::{DriveSpec, generate};
    use crate::image_sim::scene::{colour_of, object_cuboid};
    use crate::track_sim::LabelBox;
    let d = generate(&DriveSpec { frames: 4, ..DriveSpec::default() });
    let sim = crate::image_sim::ImageSim::new(Camera::kitti(0.2), &d.camera_poses, &LabelBox::of_drive(&d), 5);
    let boxes = sim.truth[k]
        .iter()
        .map(|o| (o.object_id, object_cuboid(o, 17 + u32::from(o.object_id), colour_of(3))))
        .collect();
    (sim.camera, sim.poses[k], sim.scene, boxes)
}

#[test]
fn tiles_on_any_number_of_threads_with_either_instruction_set_give_the_reference_view() {
    for optics in [Optics::IDEAL, Optics::CAMERA] {
        for k in [0, 3] {
            let (cam, pose, scene, boxes) = drive_scene(k);
            let cam = Camera { optics, ..cam };
            let want = reference(&cam, &pose, &scene, &boxes, 9);
            assert!(want.ids.iter().any(|&id| id != 0), "an object in view");
            // The generic build and the one for this CPU (AVX2 where it has it).
            for (threads, for_this_cpu) in [1, 2, 3, 64].into_iter().flat_map(|t| [(t, false), (t, true)]) {
                let view = render_with(&cam, &pose, &scene, &boxes, 9, threads, for_this_cpu);
                let bits = |v: &View| v.depth.iter().map(|z| z.to_bits()).collect::<Vec<_>>();
                let case = format!("{optics:?} frame {k}, {threads} threads, for this CPU {for_this_cpu}");
                assert!(view.rgb == want.rgb && view.ids == want.ids, "{case}");
                assert_eq!(bits(&view), bits(&want), "{case}");
            }
        }
    }
}

#[test]
fn an_empty_image_renders_empty() {
    // Boxes in view of an image without pixels have no rectangle: none here.
    let (cam, pose, scene, _) = drive_scene(0);
    let scene = StaticScene { structures: Vec::new(), ..scene };
    for (width, height) in [(0, 5), (5, 0), (0, 0)] {
        let view = render_with_threads(&Camera { width, height, ..cam }, &pose, &scene, &[], 1, 2);
        assert!(view.rgb.is_empty() && view.depth.is_empty() && view.ids.is_empty());
    }
}

#[test]
fn the_masked_box_test_is_the_branching_one() {
    let mut r = 0x0bad_5eedu32;
    let mut next = || {
        r = hash(r);
        f64::from(r) / f64::from(u32::MAX) - 0.5
    };
    let special = [0.0, -0.0, 1e-13, -1e-13, 1e-12, 0.5, -0.5, 1.0, f64::INFINITY];
    for k in 0..400_000 {
        let half = Vector3::new(next().abs() * 6.0, next().abs() * 3.0, next().abs() * 2.0);
        let mut origin = Point3::new(next() * 40.0, next() * 10.0, next() * 40.0);
        let mut dir = Vector3::new(next(), next(), next());
        // Rays along the faces' planes, from their corners, parallel to axes.
        if k % 7 == 0 {
            dir[k % 3] = special[k / 7 % special.len()];
        }
        if k % 11 == 0 {
            origin[k % 3] = half[k % 3] * [1.0, -1.0][k / 11 % 2];
        }
        let want = hit_box(&origin, &dir, &half);
        let (found, t, p, axis, positive) = hit_box_masked(&origin, &dir, &half);
        assert_eq!(found, want.is_some(), "{origin} {dir} {half}");
        if let Some((wt, wp, waxis, wsign)) = want {
            assert_eq!((t.to_bits(), axis as usize, positive), (wt.to_bits(), waxis, wsign > 0.0), "{origin} {dir}");
            assert!(p.coords.iter().zip(wp.coords.iter()).all(|(a, b)| a.to_bits() == b.to_bits()), "{origin} {dir}");
        }
    }
}

#[test]
fn boxes_partly_behind_the_camera_give_the_reference_view() {
    // Boxes around the camera, turned every way, most of them straddling its plane: the rows
    // tested are those of the part in front, which must hold every pixel the reference hits.
    let cam = Camera { optics: Optics::IDEAL, ..Camera::kitti(0.15) };
    let scene = StaticScene { ground: GroundPlane::level(1.65), ground_texture: 1, structures: Vec::new() };
    let mut r = 0x5eed_0001u32;
    let mut next = || {
        r = hash(r);
        f64::from(r) / f64::from(u32::MAX) - 0.5
    };
    let (mut straddling, mut near) = (0, 0);
    for k in 0..60 {
        let boxes: Vec<(u16, Cuboid)> = (0..4)
            .map(|i| {
                let axis = nalgebra::Vector3::new(next(), next(), next());
                let rotation = nalgebra::UnitQuaternion::from_scaled_axis(axis * 6.0);
                // Beside, above or below the camera, reaching from behind it to just in front.
                let side = if i % 2 == 0 { 1.0 } else { -1.0 };
                let (x, y) = (side * (0.4 + 4.0 * next().abs()), next() * 2.0);
                let centre =
                    if i < 2 { Translation3::new(x, y, next() * 3.0) } else { Translation3::new(y, x, next() * 3.0) };
                let half = Vector3::new(0.1 + next().abs() * 3.0, 0.1 + next().abs() * 3.0, 0.1 + next().abs() * 3.0);
                // The last one square to the camera, its front face a few centimetres ahead.
                let (centre, rotation) = if i == 3 {
                    let front = 0.06 + 0.3 * next().abs();
                    // Its side a little off the axis: the camera outside, the near face in view.
                    let x = side * (half.x + 0.02 + 0.2 * next().abs());
                    (Translation3::new(x, next() * 0.5, front - half.z), nalgebra::UnitQuaternion::identity())
                } else {
                    (centre, rotation)
                };
                let c = Cuboid {
                    pose: Isometry3::from_parts(centre, rotation),
                    half,
                    texture: 3 + i,
                    colour: [0.8, 0.4, 0.2],
                    texture_scale: 1.0,
                };
                (i as u16 + 1, c)
            })
            .collect();
        let pose = Isometry3::identity();
        straddling += boxes
            .iter()
            .filter(|(_, c)| {
                let z = |s: f64| (c.pose * Point3::new(s * c.half.x, s * c.half.y, s * c.half.z)).z;
                z(1.0).min(z(-1.0)) < 0.05 && z(1.0).max(z(-1.0)) > 0.05
            })
            .count();
        let want = reference(&cam, &pose, &scene, &boxes, k);
        near += want.depth.iter().filter(|&&z| z > 0.0 && z < 0.5).count();
        for for_this_cpu in [false, true] {
            let view = render_with(&cam, &pose, &scene, &boxes, k, 1, for_this_cpu);
            assert!(view.rgb == want.rgb && view.ids == want.ids, "scene {k}, for this CPU {for_this_cpu}");
            assert!(view.depth.iter().zip(&want.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "scene {k}");
        }
    }
    assert!(straddling > 30, "{straddling} boxes straddle the camera's plane");
    assert!(near > 1000, "{near} pixels nearer than 0.5 m");
}
