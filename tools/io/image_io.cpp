// ffseg tools: the format dispatcher (see image_io.h).
#include "image_io.h"

#include <sys/stat.h>

#include <cstdio>
#include <cstring>

#include "byte_io.h"
#include "dicom_series.h"
#include "metaimage.h"
#include "nrrd.h"

namespace ffseg_tools {

const char* image_format_name(ImageFormat f) {
    switch (f) {
        case ImageFormat::Nifti: return "nifti";
        case ImageFormat::Nrrd: return "nrrd";
        case ImageFormat::MetaImage: return "metaimage";
        case ImageFormat::Dicom: return "dicom";
    }
    return "?";
}

bool image_format_from_name(const std::string& n, ImageFormat* f) {
    if (n == "nifti") *f = ImageFormat::Nifti;
    else if (n == "nrrd") *f = ImageFormat::Nrrd;
    else if (n == "metaimage" || n == "mha") *f = ImageFormat::MetaImage;
    else if (n == "dicom") *f = ImageFormat::Dicom;
    else return false;
    return true;
}

ImageFormat image_format_of_path(const std::string& path) {
    struct stat st;
    if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) return ImageFormat::Dicom;
    using io::ends_with_ci;
    if (ends_with_ci(path, ".nii") || ends_with_ci(path, ".nii.gz")) return ImageFormat::Nifti;
    if (ends_with_ci(path, ".nrrd") || ends_with_ci(path, ".nhdr")) return ImageFormat::Nrrd;
    if (ends_with_ci(path, ".mha") || ends_with_ci(path, ".mhd")) return ImageFormat::MetaImage;
    char head[16] = {0};
    if (FILE* f = std::fopen(path.c_str(), "rb")) {
        const size_t got = std::fread(head, 1, sizeof head - 1, f);
        head[got] = 0;
        std::fclose(f);
    }
    if (std::strncmp(head, "NRRD000", 7) == 0) return ImageFormat::Nrrd;
    if (std::strncmp(head, "ObjectType", 10) == 0 || std::strncmp(head, "NDims", 5) == 0) return ImageFormat::MetaImage;
    return ImageFormat::Nifti;
}

bool image_read_file(const std::string& path, NiftiImage* out, ImageFormat* format, std::string* err,
                     const NiftiLimits& lim, DicomSource* dicom) {
    const ImageFormat f = image_format_of_path(path);
    if (format) *format = f;
    switch (f) {
        case ImageFormat::Nifti: return nifti_read_file(path, out, err, lim);
        case ImageFormat::Nrrd: return nrrd_read_file(path, out, err, lim);
        case ImageFormat::MetaImage: return metaimage_read_file(path, out, err, lim);
        case ImageFormat::Dicom: return dicom_read_series(path, out, err, lim, dicom);
    }
    return io::fail(err, "unknown format");
}

const char* label_file_name(ImageFormat f) {
    switch (f) {
        case ImageFormat::Nrrd: return "labels.nrrd";
        case ImageFormat::MetaImage: return "labels.mha";
        default: return "labels.nii.gz";
    }
}

bool image_write_file(const std::string& path, ImageFormat f, const NiftiImage& img, std::string* err) {
    switch (f) {
        case ImageFormat::Nrrd: return nrrd_write_file(path, img, err);
        case ImageFormat::MetaImage: return metaimage_write_file(path, img, err);
        default: return nifti_write_file(path, img, err);
    }
}

}  // namespace ffseg_tools
