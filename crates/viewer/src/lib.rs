//! Writes arcsim timelines and sweeps for the Rerun viewer.
