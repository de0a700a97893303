//! Chains layer windows and transitions into one verified gantry timeline; speed schedules.
