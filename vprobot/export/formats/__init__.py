"""The export formats, one module each, registered in `FORMATS` (`base`), which imports every
module of this package when first read: `trajectory` (JSON), `csv`, `urscript`, `ros2`,
`acquisitions`."""

from vprobot.export.formats.base import (
    FORMATS,
    ExportFormat,
    export_plan,
    export_plan_file,
    register_format,
)

__all__ = ["FORMATS", "ExportFormat", "export_plan", "export_plan_file", "register_format"]
