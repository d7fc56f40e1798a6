//! The pyroclastic domain step (`volcano_plume::model::flows::step`) alone, without an App,
//! does what the plugin does: fed the slices the plume handed over in each step, it holds the
//! same particles, books and deposit bit for bit after 40 s of a collapsing column on a cone;
//! and a game system ordered after `PyroclasticSystems::Step` sees each step's result.

use crate::common;

use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_plume::model::flows::{self, Collapsed, FlowInputs, FlowsState, VolcanoFlows, VolcanoInputs};
use volcano_plume::*;

/// What the pyroclastic domain read in each of its steps: the collapsed slices, and the
/// deposit's relaxation passes due. Recorded before the step.
#[derive(Resource, Default)]
struct Steps(Vec<(Vec<Collapsed>, u32)>);

fn record(time: Res<Time>, mut collapsed: MessageReader<SliceCollapsed>, mut steps: ResMut<Steps>) {
    let slices = collapsed
        .read()
        .map(|SliceCollapsed(s)| Collapsed { index: s.index, vent: s.vent, state: s.state.clone() })
        .collect();
    let (period, offset) = flows::RELAX_PERIOD;
    let relax = volcano_core::clock::crossings(time.elapsed(), time.delta(), period, offset) as u32;
    steps.0.push((slices, relax));
}

/// Particles a game system saw after each step.
#[derive(Resource, Default)]
struct Seen(Vec<usize>);

fn after_step(particles: Query<&PyroParticle>, mut seen: ResMut<Seen>) {
    seen.0.push(particles.iter().count());
}

fn app() -> App {
    let mut app = common::plume_app(5);
    app.init_resource::<Steps>()
        .init_resource::<Seen>()
        .add_systems(PyroclasticStep, record.in_set(PyroclasticSystems::Prepare))
        .add_systems(PyroclasticStep, after_step.after(PyroclasticSystems::Step));
    let mut eruption = Eruption::pyroclastic();
    eruption.active = true;
    common::spawn_collapsing_cone(&mut app, eruption);
    app
}

#[test]
fn the_model_step_alone_equals_the_plugin() {
    let mut app = app();
    common::run(&mut app, 50 * 40);
    let world = app.world_mut();
    let terrain = world.query::<&Terrain>().single(world).unwrap().clone();
    let (eruption, rng, budget) =
        world.query::<(&Eruption, &VolcanoRng, &PyroclasticBudget)>().single(world).unwrap();
    let (eruption, rng, budget) = (eruption.clone(), rng.clone(), *budget);
    let deposit = world.query::<&DepositMap>().single(world).unwrap().clone();
    let mut plugin: Vec<(u64, [u64; 4], bool)> = world
        .query::<&PyroParticle>()
        .iter(world)
        .map(|p| {
            let q = &p.particle;
            (p.id, [q.position.x, q.position.y, q.position.z, q.mass].map(f64::to_bits), p.buoyant)
        })
        .collect();
    plugin.sort();
    let steps = std::mem::take(&mut world.resource_mut::<Steps>().0);
    let seen = std::mem::take(&mut world.resource_mut::<Seen>().0);
    assert!(steps.iter().any(|(c, _)| !c.is_empty()), "the column collapsed");

    // The same steps on plain data.
    let caps = PlumeCaps::default();
    let mut state =
        FlowsState { volcanoes: vec![VolcanoFlows::default()], grounds: vec![DepositMap::default()] };
    for (n, (collapsed, relax)) in steps.iter().enumerate() {
        let volcanoes = [VolcanoInputs {
            plume: &eruption.params,
            pyroclastic: &eruption.pyroclastic,
            rng: &rng,
            ground: Some(0),
            collapsed,
        }];
        flows::step(
            &mut state,
            &FlowInputs {
                dt: 0.02,
                relax_passes: *relax,
                max_particles: caps.max_particles as usize,
                max_secondary_per_step: caps.max_secondary_per_step as usize,
                volcanoes: &volcanoes,
                terrains: &[&terrain],
            },
        );
        assert_eq!(state.particle_count(), seen[n], "particles after step {n}");
    }
    let mut model: Vec<(u64, [u64; 4], bool)> = state.volcanoes[0]
        .particles
        .iter()
        .map(|p| {
            let q = &p.particle;
            (p.id, [q.position.x, q.position.y, q.position.z, q.mass].map(f64::to_bits), p.buoyant)
        })
        .collect();
    model.sort();
    assert!(plugin.len() > 1_000, "a flow is running: {} particles", plugin.len());
    assert_eq!(model, plugin);
    assert_eq!(state.volcanoes[0].budget, budget);
    let bits =
        |d: &DepositMap| d.mass.as_ref().map(|m| m.data().iter().map(|x| x.to_bits()).collect::<Vec<_>>());
    assert_eq!(bits(&state.grounds[0]), bits(&deposit));
    assert!(budget.deposited > 0.0, "{budget:?}");
}
