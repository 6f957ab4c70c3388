"""Files: where vprobot's own files are (`paths`), writing outputs atomically, locks and
caches (`atomic`), checking output options (`outputs`), the YAML schemas every file
format builds on (`schema`) and the progress of long jobs (`progress`).
"""
