//! Examples of firn used as a library; see the `[[example]]` targets.
