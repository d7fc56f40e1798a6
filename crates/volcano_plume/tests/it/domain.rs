//! The plume domain step (`volcano_plume::model::domain::step`) alone, without an App, does what the plugin
//! does: the same slices bit for bit after 60 s of the thesis preset at the thesis' 50 Hz tick;
//! and a game system ordered after `PlumeSystems::Step` sees each step's result.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_plume::model::domain::{Emitter, LiveSlice, StepCaps, step};
use volcano_plume::*;

fn app(eruption: Eruption, ticks_per_update: u32) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20) * ticks_per_update));
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    app.world_mut().spawn((Volcano::new(100.0, 11).unwrap(), eruption, Transform::default()));
    app
}

fn run(app: &mut App, ticks: u64) {
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
}

/// The volcano's eruption, vent and random state, as the plugin sees them.
fn volcano(app: &mut App) -> (Eruption, Vec3, VolcanoRng) {
    let world = app.world_mut();
    let (e, v, r) = world.query::<(&Eruption, &VentPosition, &VolcanoRng)>().single(world).unwrap();
    (e.clone(), v.0, r.clone())
}

/// Runs the model step alone for `steps` steps of `dt` from an empty plume, calling `each`
/// after every step.
fn model_run(
    eruption: &Eruption,
    vent: Vec3,
    rng: &VolcanoRng,
    dt: f64,
    steps: u64,
    mut each: impl FnMut(u64, &PlumeState, &PlumeReport),
) -> PlumeState {
    let mut state = PlumeState::default();
    let inputs = PlumeInputs {
        params: &eruption.params,
        spheres: &eruption.spheres,
        active: eruption.active,
        frozen: false,
        emitter: Some(Emitter { vent, rng }),
        umbrella_lifetime: eruption.umbrella_lifetime,
        umbrella_fallout_s: eruption.umbrella_fallout_s,
        air: PlumeAir::Own,
        caps: StepCaps::default(),
        rings: None,
        dt,
        umbrella_dt: 0.0,
    };
    for n in 1..=steps {
        // As the plugin: the umbrella steps once per base tick (ten steps), on its last step.
        let umbrella_dt = if n % 10 == 0 { Duration::from_millis(20).as_secs_f64() } else { 0.0 };
        let report = step(&mut state, &PlumeInputs { umbrella_dt, ..inputs });
        each(n, &state, &report);
    }
    state
}

/// Bits of a slice's state and of what it carries.
fn bits(s: &Slice, ring_phase: f64, ash_pending: f64) -> Vec<u64> {
    let mut v = vec![
        s.r,
        s.length,
        s.density,
        s.temperature,
        s.mass,
        s.age,
        s.apex,
        s.initial_mass,
        s.entrained_mass,
        s.sedimented_mass,
        s.solid_mass,
        s.water_mass,
        ring_phase,
        ash_pending,
    ];
    v.extend(s.position.to_array());
    v.extend(s.velocity.to_array());
    v.into_iter().map(f64::to_bits).collect()
}

#[test]
fn the_model_step_alone_matches_the_plugin_bit_for_bit() {
    let seconds = 60;
    let mut app = app(Eruption::thesis(), 5);
    run(&mut app, 50 * seconds);
    let dt = app.world().resource::<Time<DomainClock<PlumeStep>>>().delta_secs_f64();
    assert_eq!(dt, 0.002, "the thesis' plume step at 50 Hz");
    let (eruption, vent, rng) = volcano(&mut app);
    let mut collapsed = 0;
    let state = model_run(&eruption, vent, &rng, dt, 50 * seconds * 10, |_, _, r| {
        collapsed += r.collapsed().count();
    });

    let world = app.world_mut();
    eprintln!(
        "{seconds} s: {} live vent slices, {collapsed} collapsed, {} secondary columns live",
        state.slices.len(),
        world.query::<&PlumeSlice>().iter(world).filter(|s| s.secondary).count()
    );
    // The vent's slices in emission order (secondary columns from the flows share the
    // numbering, so they are left out and the vent's are matched by order).
    let mut plugin: Vec<&PlumeSlice> =
        world.query::<&PlumeSlice>().iter(world).filter(|s| !s.secondary).collect();
    plugin.sort_by_key(|s| s.index);
    assert!(collapsed > 10, "the thesis column collapses ({collapsed} slices in {seconds} s)");
    assert!(state.slices.len() > 50, "{} live slices", state.slices.len());
    assert_eq!(plugin.len(), state.slices.len(), "live vent slices");
    for (p, m) in plugin.iter().zip(&state.slices) {
        assert_eq!(p.state.phase, m.state.phase);
        assert_eq!(
            bits(&p.state, p.ring_phase, p.ash_pending),
            bits(&m.state, m.ring_phase, m.ash_pending),
            "slice {} (model {})",
            p.index,
            m.index
        );
    }
    // Emission and the ash books.
    let emission = world.query::<&EmissionState>().single(world).unwrap().clone();
    let secondary = volcano_plume::ground::all_budgets(world).secondary_columns;
    assert_eq!(emission.emitted - secondary, state.emission.emitted);
    assert_eq!(emission.since_last.to_bits(), state.emission.since_last.to_bits());
    let books = *world.query::<&PlumeAshBudget>().single(world).unwrap();
    assert_eq!(books.emitted_kg.to_bits(), state.ash.emitted_kg.to_bits());
    assert!(
        (books.to_flows_kg - state.ash.to_flows_kg).abs() <= 1e-12 * books.to_flows_kg
            && books.to_flows_kg > 0.0,
        "to the flows: plugin {} kg, model {} kg",
        books.to_flows_kg,
        state.ash.to_flows_kg
    );
}

/// What a game system ordered after `PlumeSystems::Step` saw on each plume step.
#[derive(Resource, Default)]
struct Seen(Vec<Vec<(u64, Vec<u64>)>>);

fn look(mut seen: ResMut<Seen>, slices: Query<&PlumeSlice>) {
    let mut now: Vec<(u64, Vec<u64>)> =
        slices.iter().map(|s| (s.index, bits(&s.state, s.ring_phase, s.ash_pending))).collect();
    now.sort();
    seen.0.push(now);
}

#[test]
fn a_game_system_after_the_step_sees_the_stepped_plume() {
    let mut app = app(Eruption::plinian(), 1);
    app.init_resource::<Seen>().add_systems(PlumeStep, look.after(PlumeSystems::Step));
    run(&mut app, 50 * 3);
    let (eruption, vent, rng) = volcano(&mut app);
    let seen = std::mem::take(&mut app.world_mut().resource_mut::<Seen>().0);
    assert_eq!(seen.len(), 50 * 3 * 10, "one look per plume step");
    let mut checked = 0;
    model_run(&eruption, vent, &rng, 0.002, seen.len() as u64, |n, state, _| {
        let mut want: Vec<(u64, Vec<u64>)> = state
            .slices
            .iter()
            .map(|s: &LiveSlice| (s.index, bits(&s.state, s.ring_phase, s.ash_pending)))
            .collect();
        want.sort();
        assert_eq!(seen[n as usize - 1], want, "plume step {n}: the game saw another state");
        checked += usize::from(!want.is_empty());
    });
    assert!(checked > 1_000, "{checked} steps with slices compared");
}

/// The plugin steps the umbrella once per base tick of plume time, by every tick a step
/// crossed: umbrella spheres age with the plume's clock at the default ten substeps per tick,
/// at one step per tick, and at one step every three ticks (a step of three ticks steps them by
/// three ticks; with one tick per crossing step they would fall behind to a third).
#[test]
fn umbrella_spheres_age_with_the_plume_clock_at_any_cadence() {
    use volcano_plume::model::umbrella::{Spread, UmbrellaSphere};
    for cadence in [Cadence::Substeps(10), Cadence::Substeps(1), Cadence::EveryNthTick(3)] {
        let mut app = app(Eruption { active: false, ..Eruption::plinian() }, 1);
        run(&mut app, 1);
        let world = app.world_mut();
        world.resource_mut::<Time<DomainClock<PlumeStep>>>().context_mut().set_cadence(cadence).unwrap();
        let volcano = world.query_filtered::<Entity, With<Eruption>>().single(world).unwrap();
        let sphere = UmbrellaSphere {
            axis: bevy::math::DVec2::ZERO,
            direction: bevy::math::DVec2::X,
            d: 500.0,
            r: 500.0,
            v_neutral: 20.0,
            z_apex: 9_000.0,
            z_neutral: 8_000.0,
            spread: Spread::Thesis,
        };
        world.spawn((
            Transform::default(),
            Umbrella {
                volcano,
                sphere,
                radius: 200.0,
                density: 0.5,
                age: 0.0,
                vent: Vec3::ZERO,
                id: 1,
                ash: 1.0,
                ash_pending: 0.0,
            },
        ));
        let before = world.resource::<Time<DomainClock<PlumeStep>>>().elapsed_secs_f64();
        run(&mut app, 1 + 60);
        let world = app.world_mut();
        let after = world.resource::<Time<DomainClock<PlumeStep>>>().elapsed_secs_f64();
        let u = world.query::<&Umbrella>().single(world).unwrap().clone();
        let elapsed = after - before;
        assert!(elapsed > 1.1, "{cadence:?}: plume time {elapsed}");
        assert!((u.age - elapsed).abs() < 1e-9, "{cadence:?}: age {} after {elapsed} s of plume time", u.age);
        assert!(u.sphere.d > 500.0 && u.ash < 1.0, "{cadence:?}: not stepped");
    }
}

/// What the deposit map held when the first pyroclastic step began: (nx, ny) of its grid.
#[derive(Resource, Default)]
struct MapAtFirstStep(Option<Option<(usize, usize)>>);

fn map_at_first_step(mut seen: ResMut<MapAtFirstStep>, maps: Query<&DepositMap>) {
    if seen.0.is_none() {
        seen.0 = Some(maps.iter().next().and_then(|m| m.mass.as_ref()).map(|g| (g.nx(), g.ny())));
    }
}

/// The deposit map of the terrain an erupting volcano stands on exists, sized to the terrain,
/// before the first pyroclastic step (created outside the ticks, its pages written), not in
/// that step nor mapped by the first relaxation after the first deposit (fails without
/// `prepare_deposit_maps`: the map has no grid then).
#[test]
fn an_erupting_volcanos_deposit_map_exists_before_the_first_step() {
    let mut app = app(Eruption::plinian(), 1);
    app.init_resource::<MapAtFirstStep>().add_systems(
        volcano_plume::PyroclasticStep,
        map_at_first_step.before(volcano_plume::PyroclasticSystems::Step),
    );
    run(&mut app, 2);
    let seen = app.world().resource::<MapAtFirstStep>().0;
    assert_eq!(seen, Some(Some((33, 33))), "the grid at the first step");
}
