//! A layer's fields shared copy-on-write between the ECS and the weather step in flight
//! (docs/ARCHITECTURE.md §3.3): starting a step hands the worker a reference, and the worker
//! copies the fields into its own buffers off the main thread. Reads go through `Deref`;
//! a write (`DerefMut`) while the worker still holds the reference copies the fields first
//! (`Arc::make_mut`), so the worker's input never changes under it. The coupling writes only
//! before a step starts and the worker lets go within milliseconds of it, so in a running
//! scene that copy does not happen.

use std::ops::{Deref, DerefMut};
use std::sync::Arc;

use crate::model::fields::LayerFields;

/// [`LayerFields`] behind a copy-on-write reference (see the module docs). Use it as a
/// `LayerFields`: `layer.fields.t`, `&*layer.fields`, `&mut *layer.fields`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SharedFields(Arc<LayerFields>);

impl SharedFields {
    /// Wraps `fields` (no copy).
    pub fn new(fields: LayerFields) -> Self {
        Self(Arc::new(fields))
    }

    /// Another reference to the same fields (no copy), for work off the main thread (the
    /// weather step, the cloud renderer's rebuild): while it is held, a write through this
    /// value copies the fields first. Let go of it as soon as the fields are copied or read.
    pub fn share(&self) -> Arc<LayerFields> {
        Arc::clone(&self.0)
    }

    /// The fields, without a copy when this is the only reference.
    pub fn into_inner(self) -> LayerFields {
        Arc::try_unwrap(self.0).unwrap_or_else(|shared| (*shared).clone())
    }
}

impl From<LayerFields> for SharedFields {
    fn from(fields: LayerFields) -> Self {
        Self::new(fields)
    }
}

impl Deref for SharedFields {
    type Target = LayerFields;
    fn deref(&self) -> &LayerFields {
        &self.0
    }
}

impl DerefMut for SharedFields {
    fn deref_mut(&mut self) -> &mut LayerFields {
        Arc::make_mut(&mut self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::fields::GridSpec;

    #[test]
    fn a_write_while_shared_leaves_the_shared_copy_unchanged() {
        let grid = GridSpec::new(16, 100.0).unwrap();
        let mut fields = SharedFields::new(LayerFields::new(grid, 500.0, 0.0, 1000.0, 290.0));
        let in_flight = fields.share();
        fields.t.data_mut()[3] = 300.0;
        assert_eq!(in_flight.t.data()[3], 290.0, "the worker's input changed");
        assert_eq!(fields.t.data()[3], 300.0);
        drop(in_flight);
        // Sole owner again: no copy on the next write, and the same buffer is given back.
        let before = fields.t.data().as_ptr();
        fields.t.data_mut()[0] = 280.0;
        assert_eq!(fields.t.data().as_ptr(), before);
        assert_eq!(fields.into_inner().t.data().as_ptr(), before);
    }
}
