//! Model layer of the coupling: plain functions over the layers' fields and a list of column
//! slices; no ECS types. [`step`] holds the coupling's two steps (before and after a weather
//! step), [`column`](mod@column) and [`inject`] the transfers they are made of, [`books`] their books.

pub mod books;
pub mod column;
pub mod heat;
pub mod inject;
pub mod step;
