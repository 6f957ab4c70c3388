"""The export formats, one module each, registered in `FORMATS` (`base`), which declares them
and imports one on the first lookup of its name: `trajectory` (JSON), `csv`, `urscript`, `ros2`,
`acquisitions`."""

from vprobot.export.formats.base import (
    FORMATS,
    ExportFormat,
    export_plan,
    export_plan_file,
    register_format,
)

__all__ = ["FORMATS", "ExportFormat", "export_plan", "export_plan_file", "register_format"]
