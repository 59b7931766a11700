"""The ground floor: staged atomic artifacts, folder locks, the config vocabulary, the sweep log, tables."""
