// `ffseg segment --html`: report.html beside report.json, a page that opens
// from disk (no server, nothing fetched) and shows the volume, every object's
// labels and mesh in the viewer of web/ (NiiVue), and the report's table.
#ifndef FFSEG_CLI_REPORT_HTML_H
#define FFSEG_CLI_REPORT_HTML_H

#include <string>
#include <vector>

namespace ffseg_cli {

// Where the page's script (web/dist/report-viewer.js, `make web-dist`) is:
// $FFSEG_VIEWER_JS, else beside the tool's build or install
// (<exe>/../web/dist/, <exe>/../share/ffseg/). "" when none exists.
std::string find_report_viewer();

// Writes dir/report.html: the viewer script and every file it shows inline
// (volume_path when it is one file the viewer reads, the label map and the
// meshes from dir, report.json's text). False with *err on failure.
bool write_report_html(const std::string& dir, const std::string& viewer_js, const std::string& volume_path,
                       const std::string& labels_file, const std::vector<std::string>& mesh_files,
                       const std::string& report_json, std::string* err);

}  // namespace ffseg_cli

#endif  // FFSEG_CLI_REPORT_HTML_H
