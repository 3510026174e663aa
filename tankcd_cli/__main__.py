from tankcd_cli.cli.main import console

if __name__ == "__main__":
    console()
