"""Figures: functions of datasets, one module per kind plus the common dispatch and the bench figure."""
