"""The export formats, one module each, registered in `FORMATS` (`base`), which declares them
and imports one on the first lookup of its name: `trajectory` (JSON), `csv`, `urscript`, `ros2`,
`acquisitions`. `vprobot.export.program` writes a plan in one of them."""

from vprobot.export.formats.base import FORMATS, ExportFormat, register_format

__all__ = ["FORMATS", "ExportFormat", "register_format"]
