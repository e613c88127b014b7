//! `osiris bench camera`: frames per second of the physical camera on a reference scene.
