# Sourced by scripts/device-check and scripts/device-sweep on a lent GPU machine (the `device`
# tool): makes the Vulkan loader and GLVND available (the NVIDIA ICD needs libGLdispatch; both
# come as .debs in .device/debs from scripts/device-bundle), points the loader at the NVIDIA ICD,
# and unpacks .device/bundle.tar.gz into $bin (/tmp/fluxswarm-device). Sets `bin`.
if [ ! -f .device/bundle.tar.gz ]; then
    echo "no .device/bundle.tar.gz; run scripts/device-bundle here first and carry .device" >&2
    exit 1
fi
if ! ldconfig -p | grep -q 'libvulkan.so.1' || ! ldconfig -p | grep -q 'libGLdispatch.so.0'; then
    for f in .device/debs/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$icd" ]; then
    export VK_DRIVER_FILES="$icd"
fi
bin=/tmp/fluxswarm-device
rm -rf "$bin" && mkdir -p "$bin"
tar -xzf .device/bundle.tar.gz -C "$bin"
export NODEVICE_SELECT=1 RUST_LOG="${RUST_LOG:-info}" RUST_BACKTRACE=1
