//! What eruptions leave on the ground and their books, per entity: a [`DepositMap`] on every
//! `Terrain` entity and a [`PyroclasticBudget`] on every volcano with an `Eruption` (the types
//! are plain data in [`crate::model::ground`]), and sums over a world's.

pub use crate::model::ground::{DepositMap, PyroclasticBudget};

/// The books of every volcano, summed (reports and tests).
pub fn all_budgets(world: &mut bevy::ecs::world::World) -> PyroclasticBudget {
    let mut sum = PyroclasticBudget::default();
    for b in world.query::<&PyroclasticBudget>().iter(world) {
        sum += *b;
    }
    sum
}

/// Mass deposited on every terrain (kg).
pub fn all_deposits(world: &mut bevy::ecs::world::World) -> f64 {
    world.query::<&DepositMap>().iter(world).map(DepositMap::total).sum()
}
