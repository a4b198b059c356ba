//! Streaming under a byte budget (issue 11): every frame's cut is crack-free while data is
//! missing, the settled cut equals the unlimited one where the view fits, a paused camera
//! stops loading when it does not, a damaged patch keeps its diamond coarse, and a long loop
//! neither stalls nor grows. The traversal here is the CPU reference (`stream::stream_frame`),
//! the same rule the GPU runs; the checks are exact (edges by global vertex id).

use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, select_stateless, select_visible};
use tessera_core::repository::patch::drawn_patch_bytes;
use tessera_core::repository::Repository;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_runtime::camera::{Camera, Y_UP};
use tessera_runtime::geometric_check::{decode_all_patches, CutChecker};
use tessera_runtime::stream::{gated_rhos, CpuStreamer, StreamSettings, UnitState, UnitTable};
use tessera_tests::{build, testdata, Built};

const TAU: f32 = 1.0;

fn units_of(repo: &Repository) -> UnitTable {
    UnitTable::new(
        repo.diamonds(),
        repo.tets(),
        repo.header().root_tet_count as usize,
        &|t| drawn_patch_bytes(t, repo.header().attributes),
    )
}

fn built(file: &str) -> Built {
    let input = load_mesh(&testdata(file)).expect("import");
    build(&input.mesh, &BuildConfig::default())
}

/// Half a turn around the model at 0.9 radii, from azimuth 150° on, after `fly_in`'s end.
fn close_orbit(repo: &Repository, frames: usize) -> Vec<Camera> {
    let h = repo.header();
    (0..frames)
        .map(|i| {
            let s = i as f64 / (frames.max(2) - 1) as f64;
            Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, 150.0 + 180.0 * s, 10.0, 0.9)
        })
        .collect()
}

/// A fly-in around the model: `frames` cameras from 3 radii out to 0.9, turning 120°.
fn fly_in(repo: &Repository, frames: usize) -> Vec<Camera> {
    let h = repo.header();
    (0..frames)
        .map(|i| {
            let s = i as f64 / (frames.max(2) - 1) as f64;
            Camera::orbit(
                h.bbox_min,
                h.bbox_max,
                Y_UP,
                30.0 + 120.0 * s,
                20.0 - 10.0 * s,
                3.0 - 2.1 * s,
            )
        })
        .collect()
}

fn cull_of(camera: &Camera) -> CullTests {
    CullTests {
        frustum: Some(camera.view_volume()),
        cones: true,
    }
}

/// Bytes of every unit that the unlimited cuts of `cameras` refine (visible simplices only),
/// plus the roots: the path's working set.
fn working_set(repo: &Repository, cameras: &[Camera]) -> u64 {
    let units = units_of(repo);
    let all = vec![true; repo.diamonds().len()];
    let mut used = vec![false; units.len()];
    for camera in cameras {
        let eye = camera.eye_local(repo.header().origin);
        let rhos = diamond_rhos(repo.diamonds(), eye, &camera.metric());
        let frame = tessera_runtime::stream::stream_frame(
            repo.tets(),
            repo.header().root_tet_count as usize,
            &rhos,
            &all,
            TAU,
            eye,
            &cull_of(camera),
        );
        // A refined diamond needs every ancestor resident too.
        let mut stack: Vec<u32> = frame.refined.iter().map(|&(d, _)| d).collect();
        while let Some(d) = stack.pop() {
            if !std::mem::replace(&mut used[d as usize], true) {
                stack.extend_from_slice(units.parents(d));
            }
        }
    }
    units.root_bytes()
        + (0..units.len() as u32)
            .filter(|&d| used[d as usize])
            .map(|d| units.bytes(d))
            .sum::<u64>()
}

fn settings(budget_bytes: u64) -> StreamSettings {
    StreamSettings {
        budget_bytes,
        upload_bytes_per_frame: 256 << 10,
        latency_frames: 2,
    }
}

/// Runs `cameras` through a streamer, checking every frame: the drawn cut is crack-free and
/// introduces no non-manifold edge (the whole cut, culling off: what every view of it shows),
/// the culled selection is the stateless rule's with ρ', the residency's invariants hold.
/// Returns the last frame's culled selection.
fn stream_checked(
    streamer: &mut CpuStreamer,
    repo: &Repository,
    checker: &CutChecker<Vec<Vec<[u32; 3]>>>,
    cameras: &[Camera],
) -> Vec<u32> {
    let mut last = Vec::new();
    for (i, camera) in cameras.iter().enumerate() {
        let eye = camera.eye_local(repo.header().origin);
        let cull = cull_of(camera);
        let f = streamer.frame(eye, &camera.metric(), TAU, &cull);
        let rhos = gated_rhos(
            &diamond_rhos(repo.diamonds(), eye, &camera.metric()),
            &f.may_refine,
        );
        let flat = select_visible(repo.tets(), &rhos, TAU, eye, &cull);
        assert_eq!(
            f.frame.selection, flat,
            "frame {i}: top-down streaming selection differs from the rule with rho'"
        );
        let whole = select_stateless(repo.tets(), &rhos, TAU);
        let findings = checker.check(&whole);
        assert_eq!(findings.cracks, 0, "frame {i}: {findings:?}");
        assert_eq!(findings.nonmanifold_introduced, 0, "frame {i}");
        streamer.residency().check_invariants().unwrap();
        assert!(f.stats.resident_bytes <= streamer.residency().budget_bytes());
        last = f.frame.selection;
    }
    last
}

/// The selection a camera gets with everything resident.
fn unlimited_selection(repo: &Repository, camera: &Camera) -> Vec<u32> {
    let eye = camera.eye_local(repo.header().origin);
    let rhos = diamond_rhos(repo.diamonds(), eye, &camera.metric());
    select_visible(repo.tets(), &rhos, TAU, eye, &cull_of(camera))
}

#[test]
fn every_streaming_frame_is_crack_free_and_the_settled_cut_is_the_unlimited_one() {
    let b = built("mesh/dragon_vrip_res2.ply.gz");
    let patches = decode_all_patches(&b.repo).unwrap();
    let checker = CutChecker::new(&b.repo, &patches);
    let mut path = fly_in(&b.repo, 40);
    path.extend(close_orbit(&b.repo, 40));
    let need = working_set(&b.repo, &path[path.len() - 1..]);
    let total = working_set(&b.repo, &path);
    eprintln!("working set: last view {need} B, whole path {total} B");
    assert!(need > units_of(&b.repo).root_bytes() && total > need);

    // A budget that fits the last view's working set exactly: the fly-in streams under
    // pressure, every frame crack-free, then the paused camera settles on the unlimited cut.
    let mut streamer = CpuStreamer::new(&b.repo, settings(need)).unwrap();
    stream_checked(&mut streamer, &b.repo, &checker, &path);
    let last = path[path.len() - 1];
    let settled = stream_checked(&mut streamer, &b.repo, &checker, &vec![last; 60]);
    assert_eq!(settled, unlimited_selection(&b.repo, &last));
    let stats = streamer.residency().stats();
    assert_eq!(
        (stats.loading_units, stats.pending_units),
        (0, 0),
        "{stats:?}"
    );
    assert!(
        stats.evictions > 0,
        "the path did not stream under pressure: {stats:?}"
    );
}

#[test]
fn a_paused_camera_stops_loading_at_half_its_working_set() {
    let b = built("mesh/armadillo.off");
    let patches = decode_all_patches(&b.repo).unwrap();
    let checker = CutChecker::new(&b.repo, &patches);
    let camera = fly_in(&b.repo, 40)[39];
    let need = working_set(&b.repo, &[camera]);
    let roots = units_of(&b.repo).root_bytes();
    let budget = roots + (need - roots) / 2;
    let mut streamer = CpuStreamer::new(&b.repo, settings(budget)).unwrap();
    stream_checked(&mut streamer, &b.repo, &checker, &vec![camera; 200]);
    let before = streamer.residency().stats();
    stream_checked(&mut streamer, &b.repo, &checker, &vec![camera; 100]);
    let after = streamer.residency().stats();
    assert_eq!(after.loads, before.loads, "loads in the last 100 frames");
    assert_eq!(
        after.evictions, before.evictions,
        "evictions in the last 100 frames"
    );
    assert!(
        after.pending_units > 0,
        "half the working set cannot hold everything"
    );
    assert!(after.peak_resident_bytes <= budget);
    // Coarser than the unlimited cut, never finer.
    let eye = camera.eye_local(b.repo.header().origin);
    let rhos = diamond_rhos(b.repo.diamonds(), eye, &camera.metric());
    let unlimited = select_stateless(b.repo.tets(), &rhos, TAU);
    let gated = select_stateless(
        b.repo.tets(),
        &gated_rhos(&rhos, streamer.residency().may_refine()),
        TAU,
    );
    let triangles = |cut: &[u32]| checker.check(cut).triangles;
    assert!(triangles(&gated) < triangles(&unlimited));
}

#[test]
fn a_damaged_patch_keeps_its_diamond_from_refining() {
    let b = built("mesh/bunny00.off");
    let path_on_disk = b.dir.path().join("model.tsr");
    let repo = &b.repo;
    let camera = fly_in(repo, 20)[19];
    // The finest unit the view refines: damage one of its patches.
    let units = units_of(repo);
    let eye = camera.eye_local(repo.header().origin);
    let rhos = diamond_rhos(repo.diamonds(), eye, &camera.metric());
    let all = vec![true; repo.diamonds().len()];
    let frame = tessera_runtime::stream::stream_frame(
        repo.tets(),
        repo.header().root_tet_count as usize,
        &rhos,
        &all,
        TAU,
        eye,
        &cull_of(&camera),
    );
    let victim = frame
        .refined
        .iter()
        .map(|&(d, _)| d)
        .max_by_key(|&d| (units.level(d), d))
        .unwrap();
    let simplex = *units
        .simplices(victim)
        .iter()
        .find(|&&t| repo.tets()[t as usize].patch_bytes > 0)
        .unwrap();
    let mut bytes = std::fs::read(&path_on_disk).unwrap();
    let patches_at = repo
        .sections()
        .iter()
        // The patch blob, whichever codec the default build writes.
        .find(|s| tessera_core::repository::format::PATCH_SECTIONS.contains(&s.kind))
        .unwrap()
        .offset;
    let at = patches_at + repo.tets()[simplex as usize].patch_offset;
    bytes[at as usize + 1] ^= 0x20;
    let damaged_path = b.dir.path().join("damaged.tsr");
    std::fs::write(&damaged_path, bytes).unwrap();
    let damaged = Repository::open(&damaged_path).unwrap();

    // The healthy patches still decode for the checker: only the damaged one is refused.
    let patches = decode_all_patches(repo).unwrap();
    let checker = CutChecker::new(repo, &patches);
    let mut streamer = CpuStreamer::new(&damaged, settings(u64::MAX)).unwrap();
    stream_checked(&mut streamer, &damaged, &checker, &vec![camera; 40]);
    assert_eq!(streamer.residency().state(victim), UnitState::Broken);
    assert!(!streamer.residency().may_refine()[victim as usize]);
    assert_eq!(streamer.failures.len(), 1);
    let message = streamer.failures[0].1.to_string();
    assert!(
        message.contains(&format!("patch of tet {simplex} is damaged")),
        "{message}"
    );
    assert_eq!(streamer.residency().stats().broken_units, 1);
}

#[test]
fn a_long_loop_under_pressure_neither_stalls_nor_grows() {
    let b = built("mesh/armadillo.off");
    let patches = decode_all_patches(&b.repo).unwrap();
    let checker = CutChecker::new(&b.repo, &patches);
    // Out and back in: 40 frames each way, then 20 paused at the loop's end.
    let mut path = fly_in(&b.repo, 40);
    path.extend(fly_in(&b.repo, 40).into_iter().rev());
    let pause = path[path.len() - 1];
    path.extend(vec![pause; 20]);
    let total = working_set(&b.repo, &path);
    let roots = units_of(&b.repo).root_bytes();
    let budget = roots + (total - roots) * 2 / 3;
    let mut streamer = CpuStreamer::new(&b.repo, settings(budget)).unwrap();
    let mut first: Option<Vec<u32>> = None;
    let loops = 2000usize.div_ceil(path.len());
    for lap in 0..loops {
        let settled = stream_checked(&mut streamer, &b.repo, &checker, &path);
        match &first {
            None => first = Some(settled),
            Some(f) => assert_eq!(&settled, f, "lap {lap} settled elsewhere"),
        }
        let stats = streamer.residency().stats();
        assert!(stats.peak_resident_bytes <= budget);
    }
    let stats = streamer.residency().stats();
    eprintln!("{} frames: {stats:?}", loops * path.len());
    assert!(loops * path.len() >= 2000);
    assert!(
        stats.evictions > 0,
        "the loop never streamed under pressure"
    );
}

/// The record budget (the GPU's record slots, `gpu::records`) binds like the byte budget: with
/// bytes unlimited and records for a fraction of the path's units, a fly-in keeps the records
/// within their budget, evicts to make room for them, keeps the invariants; and the changed
/// flags the residency reports (what the GPU streamer rewrites as child links) are exactly
/// the diamonds whose flag differs from the previous frame's.
#[test]
fn the_record_budget_binds_and_changed_flags_are_reported_exactly() {
    use tessera_runtime::stream::{stream_frame, Residency};
    let b = built("mesh/armadillo.off");
    let repo = &b.repo;
    let units = units_of(repo);
    let path = fly_in(repo, 40);
    let roots = units.roots().len() as u64;
    let mut residency = Residency::with_records(units, u64::MAX, roots + 120).unwrap();
    residency.track_changed_flags();
    let mut previous = residency.may_refine().to_vec();
    for (i, camera) in path.iter().enumerate() {
        let eye = camera.eye_local(repo.header().origin);
        let rhos = diamond_rhos(repo.diamonds(), eye, &camera.metric());
        let frame = stream_frame(
            repo.tets(),
            repo.header().root_tet_count as usize,
            &rhos,
            residency.may_refine(),
            TAU,
            eye,
            &cull_of(camera),
        );
        residency.feedback(&frame.refined, &frame.wanted);
        let plan = residency.plan(u64::MAX);
        for &u in &plan.load {
            residency.complete(u, true);
        }
        residency.check_invariants().unwrap();
        let stats = residency.stats();
        assert!(
            stats.resident_records <= roots + 120,
            "frame {i}: {stats:?}"
        );
        let now = residency.may_refine().to_vec();
        let differ: Vec<u32> = (0..now.len() as u32)
            .filter(|&d| now[d as usize] != previous[d as usize])
            .collect();
        let reported: Vec<u32> = residency
            .take_changed_flags()
            .into_iter()
            .filter(|&d| now[d as usize] != previous[d as usize])
            .collect();
        assert_eq!(reported, differ, "frame {i}: changed flags");
        previous = now;
    }
    let stats = residency.stats();
    assert!(stats.evictions > 0, "records never bound: {stats:?}");
    assert!(stats.pending_units > 0, "{stats:?}");
}

/// A unit table by hand: one pinned root simplex of 8 bytes, then per diamond its parents and
/// the patch sizes of the simplices its split creates (ids only; no patch is ever read).
fn hand_units(diamonds: &[(&[u32], &[u32])]) -> UnitTable {
    use tessera_core::repository::format::{DiamondRecord, TetRecord, NO_INDEX};
    let mut records = Vec::new();
    let mut tets = vec![TetRecord {
        parent_diamond: NO_INDEX,
        patch_bytes: 8,
        ..bytemuck::Zeroable::zeroed()
    }];
    for (d, &(parents, patches)) in diamonds.iter().enumerate() {
        let mut record = DiamondRecord {
            parents: [NO_INDEX; 4],
            parent_count: parents.len() as u8,
            level: parents.len() as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        record.parents[..parents.len()].copy_from_slice(parents);
        records.push(record);
        tets.extend(patches.iter().map(|&bytes| TetRecord {
            parent_diamond: d as u32,
            patch_bytes: bytes,
            ..bytemuck::Zeroable::zeroed()
        }));
    }
    UnitTable::new(&records, &tets, 1, &|t| t.patch_bytes as u64)
}

/// A request that needs more room than any one unit without resident children frees must
/// still load when evicting such units and then the parents they leave childless makes the
/// room (children first), and only then: no unit is evicted for a load that cannot fit, nor
/// for a request that does not outrank it. Diamond 1 refines diamond 0 (100 bytes each); 2 is
/// another branch of 150 bytes; the budget holds the root, 0 and 1, and 40 bytes more.
#[test]
fn a_request_larger_than_any_leaf_unit_evicts_a_chain_and_never_stalls() {
    use tessera_runtime::stream::Residency;
    let units = hand_units(&[(&[], &[50, 50]), (&[0], &[50, 50]), (&[], &[75, 75])]);
    let mut residency = Residency::new(units, 8 + 200 + 40).unwrap();
    // A low-priority view refines through 0 and 1: both load and fill the budget but 40 bytes.
    residency.feedback(&[], &[(1, 0.5)]);
    let plan = residency.plan(u64::MAX);
    assert_eq!((plan.load.as_slice(), plan.evict.len()), (&[0, 1][..], 0));
    for u in plan.load {
        residency.complete(u, true);
    }
    residency.check_invariants().unwrap();

    // Unit 0 is used by a request that outranks the new one: evicting 1 alone frees 100 of the
    // 110 bytes needed, so nothing is evicted and nothing loads (no thrash).
    residency.feedback(&[(0, 20.0)], &[(2, 10.0)]);
    let plan = residency.plan(u64::MAX);
    assert!(plan.load.is_empty() && plan.evict.is_empty(), "{plan:?}");
    residency.check_invariants().unwrap();

    // The view moves to 2 alone: 0 and 1 are unused and 2 outranks them. Every frame the same
    // request; it must load within a frame, evicting 1 and then 0 (children first).
    let mut frames = 0;
    while residency.state(2) == UnitState::Absent && frames < 100 {
        frames += 1;
        residency.feedback(&[], &[(2, 10.0)]);
        let plan = residency.plan(u64::MAX);
        residency.check_invariants().unwrap();
        if !plan.load.is_empty() {
            assert_eq!((plan.evict, plan.load), (vec![1, 0], vec![2]));
            residency.complete(2, true);
        }
    }
    assert_eq!(
        residency.state(2),
        UnitState::Resident,
        "unit 2 never loaded in {frames} frames: {:?}",
        residency.stats()
    );
    assert_eq!(frames, 1);
    assert!(residency.may_refine()[2]);
    residency.check_invariants().unwrap();
}

/// A parent that one load's victims leave without live children is a victim for the next
/// load of the same plan: 2 (60 bytes) evicts 1, then 3 (100 bytes) evicts 0, in one frame.
#[test]
fn a_parent_left_childless_by_one_load_makes_room_for_the_next_in_the_same_plan() {
    use tessera_runtime::stream::Residency;
    let units = hand_units(&[
        (&[], &[50, 50]),
        (&[0], &[50, 50]),
        (&[], &[60]),
        (&[], &[100]),
    ]);
    let mut residency = Residency::new(units, 8 + 200 + 40).unwrap();
    residency.feedback(&[], &[(1, 0.5)]);
    for u in residency.plan(u64::MAX).load {
        residency.complete(u, true);
    }
    residency.feedback(&[], &[(2, 10.0), (3, 9.0)]);
    let plan = residency.plan(u64::MAX);
    assert_eq!((plan.evict, plan.load), (vec![1, 0], vec![2, 3]));
    residency.check_invariants().unwrap();
}

/// The highest-priority request a settled residency leaves absent although room could be made
/// for it: the free bytes plus every resident unit that a load of its priority may evict,
/// children first — a unit whose eviction key (the priority of the highest-priority diamond
/// at or below it in this frame's feedback, -1 when unused) is below the request's and whose
/// every live child may be evicted too. Returns (unit, priority, bytes, room). Computed from
/// the rule alone, not from `Residency::plan`.
fn request_with_room(
    residency: &tessera_runtime::stream::Residency,
    refined: &[(u32, f32)],
    wanted: &[(u32, f32)],
) -> Option<(u32, f32, u64, u64)> {
    let units = residency.units();
    let n = units.len();
    // As `Residency::feedback`: each ancestor of a seed takes the highest seed priority.
    let mut priority: Vec<Option<f32>> = vec![None; n];
    let mut seeds: Vec<(u32, f32)> = refined.iter().chain(wanted).copied().collect();
    seeds.sort_by(|a, b| b.1.total_cmp(&a.1));
    for (d, p) in seeds {
        let mut stack = vec![d];
        while let Some(a) = stack.pop() {
            if priority[a as usize].is_none() {
                priority[a as usize] = Some(p);
                stack.extend_from_slice(units.parents(a));
            }
        }
    }
    let key = |v: u32| priority[v as usize].unwrap_or(-1.0);
    // May a load of priority `request` evict `v` (and, first, its live descendants)?
    fn evictable_for(
        v: u32,
        request: f32,
        residency: &tessera_runtime::stream::Residency,
        key: &dyn Fn(u32) -> f32,
        memo: &mut [Option<bool>],
    ) -> bool {
        if let Some(known) = memo[v as usize] {
            return known;
        }
        let may = residency.state(v) == UnitState::Resident
            && key(v) < request
            && residency.units().children(v).iter().all(|&c| {
                !matches!(residency.state(c), UnitState::Resident | UnitState::Loading)
                    || evictable_for(c, request, residency, key, memo)
            });
        memo[v as usize] = Some(may);
        may
    }
    let free = residency.budget_bytes() - residency.stats().resident_bytes;
    let mut worst: Option<(u32, f32, u64, u64)> = None;
    for u in 0..n as u32 {
        let Some(request) = priority[u as usize] else {
            continue;
        };
        if residency.state(u) != UnitState::Absent || worst.is_some_and(|w| w.1 >= request) {
            continue;
        }
        let mut memo = vec![None; n];
        let room = free
            + (0..n as u32)
                .filter(|&v| evictable_for(v, request, residency, &key, &mut memo))
                .map(|v| units.bytes(v))
                .sum::<u64>();
        if room >= units.bytes(u) {
            worst = Some((u, request, units.bytes(u), room));
        }
    }
    worst
}

/// Loading never stalls on real repositories: after a close view and then the opposite one,
/// each under budgets from a quarter of their working set up, the paused camera settles (no
/// load nor eviction in its last 50 frames) with no request left absent that lower-priority
/// units, evicted children first, could make room for. Before chains could be evicted, 12
/// of the 80 pairs here (over the bunny, the armadillo, the dragon and the lion head) settled
/// with such a request, one of them of ρ/τ 5·10⁶ with five times its bytes available.
#[test]
fn a_paused_camera_leaves_no_request_that_lower_priority_units_make_room_for() {
    for file in [
        "mesh/bunny00.off",
        "mesh/armadillo.off",
        "mesh/dragon_vrip_res2.ply.gz",
        "mesh/lion-head.off",
    ] {
        let b = built(file);
        let repo = &b.repo;
        let h = repo.header();
        let roots = units_of(repo).root_bytes();
        for azimuth in [0.0, 90.0] {
            for distance in [0.5, 0.9] {
                let first = Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, azimuth, 10.0, distance);
                let second = Camera::orbit(
                    h.bbox_min,
                    h.bbox_max,
                    Y_UP,
                    azimuth + 180.0,
                    10.0,
                    distance,
                );
                let need = working_set(repo, &[first]).max(working_set(repo, &[second]));
                for fraction in [0.25, 0.4, 0.55, 0.7, 0.85] {
                    let budget = roots + ((need - roots) as f64 * fraction) as u64;
                    let mut streamer = CpuStreamer::new(repo, settings(budget)).unwrap();
                    let case =
                        format!("{file} azimuth {azimuth} distance {distance} budget {budget}");
                    let run = |streamer: &mut CpuStreamer, camera: &Camera, frames: usize| {
                        let eye = camera.eye_local(h.origin);
                        let mut last = None;
                        for _ in 0..frames {
                            let f = streamer.frame(eye, &camera.metric(), TAU, &cull_of(camera));
                            streamer.residency().check_invariants().unwrap();
                            assert!(f.stats.resident_bytes <= budget, "{case}");
                            last = Some(f);
                        }
                        last.unwrap()
                    };
                    run(&mut streamer, &first, 150);
                    run(&mut streamer, &second, 150);
                    let before = streamer.residency().stats();
                    let last = run(&mut streamer, &second, 50);
                    let after = streamer.residency().stats();
                    assert_eq!(
                        (after.loads, after.evictions),
                        (before.loads, before.evictions),
                        "{case}: the paused camera did not settle"
                    );
                    let stalled = request_with_room(
                        streamer.residency(),
                        &last.frame.refined,
                        &last.frame.wanted,
                    );
                    assert_eq!(
                        stalled, None,
                        "{case}: (unit, priority, bytes, room) of a request that could load"
                    );
                }
            }
        }
    }
}

/// A load the GPU pool cannot place for want of one free range (fragmentation) is given back
/// (`withdraw`): absent again and not issued again, so a still camera settles, until an
/// eviction frees room; units may be evicted for such room only below the waiting unit's
/// priority (`stream/residency/space.rs`).
#[test]
fn a_withdrawn_load_waits_for_an_eviction_and_space_victims_rank_below_it() {
    use tessera_runtime::stream::Residency;
    let units = hand_units(&[(&[], &[50, 50]), (&[], &[75, 75])]);
    let mut residency = Residency::new(units, 1 << 20).unwrap();
    residency.feedback(&[], &[(0, 1.0), (1, 0.5)]);
    let plan = residency.plan(u64::MAX);
    assert_eq!(plan.load, vec![0, 1]);
    residency.complete(0, true);
    // The next frame: unit 1 loaded, but no page can take it, and unit 0 (in use, priority
    // 1) outranks it: given back.
    residency.feedback(&[], &[(0, 1.0), (1, 0.5)]);
    assert!(!residency.may_evict_for(0, 1));
    residency.withdraw(1);
    residency.check_invariants().unwrap();
    assert_eq!(residency.state(1), UnitState::Absent);
    assert_eq!(residency.stats().withdrawn_loads, 1);
    assert_eq!(residency.stats().loading_units, 0);
    // The same view again and again: 1 is wanted but not issued again, nothing loads.
    for _ in 0..3 {
        residency.feedback(&[], &[(0, 1.0), (1, 0.5)]);
        let plan = residency.plan(u64::MAX);
        assert!(plan.load.is_empty() && plan.evict.is_empty(), "{plan:?}");
        assert_eq!(residency.stats().pending_units, 1);
    }
    // The view turns to 1 alone: unit 0 is unused now, below 1's priority, and may go for
    // room; its eviction lets 1 be issued again.
    residency.feedback(&[], &[(1, 2.0)]);
    assert!(residency.may_evict_for(0, 1));
    residency.evict_for_space(0);
    residency.check_invariants().unwrap();
    let plan = residency.plan(u64::MAX);
    assert_eq!(plan.load, vec![1]);
    residency.complete(1, true);
    residency.check_invariants().unwrap();
    assert_eq!(residency.stats().space_evictions, 1);
    assert!(residency.may_refine()[1] && !residency.may_refine()[0]);
}
