// Placeholder until the stc_sided tests land.
