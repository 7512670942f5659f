#include <cstdio>

int main() {
    std::puts("formfactor " FF_VERSION);
    return 0;
}
